"""The ground station's data link as PX4's commander sees it (PX4 main 02e73e3b6f): MavlinkReceiver::CheckHeartbeats
puts a MAV_TYPE_GCS HEARTBEAT in telemetry_status for HEARTBEAT_TIMEOUT_US, looking every half of it, and
Commander::dataLinkCheck calls the link lost when no telemetry_status had one for COM_DL_LOSS_T. There is no
ground station at boot (Commander's constructor). Pure: time is passed in."""

from offboard_py.dialect import mavlink

GCS_HEARTBEAT_TIMEOUT_S = 2.5  # telemetry_status HEARTBEAT_TIMEOUT_US
GCS_HEARTBEAT_CHECK_S = GCS_HEARTBEAT_TIMEOUT_S / 2


class DataLink:
    def __init__(self, params, now_s):
        self.params = params
        self.lost = True
        self.heartbeat_s = None  # the last GCS HEARTBEAT
        self.seen_s = None       # the last telemetry_status that had one
        self.checked_s = now_s

    def on_gcs_heartbeat(self, now_s):
        self.heartbeat_s = now_s

    def check(self, now_s):
        """Commander::dataLinkCheck; returns [(severity, text)] of the lines it logs."""
        said = []
        if now_s - self.checked_s >= GCS_HEARTBEAT_CHECK_S:
            self.checked_s = now_s
            if self.heartbeat_s is not None and now_s - self.heartbeat_s <= GCS_HEARTBEAT_TIMEOUT_S:
                if self.lost:
                    self.lost = False
                    if self.seen_s is not None:
                        said.append((mavlink.MAV_SEVERITY_INFO, 'GCS connection regained\t'))
                self.seen_s = now_s
        if not self.lost and self.seen_s is not None and now_s - self.seen_s > self.params['COM_DL_LOSS_T']:
            self.lost = True
            said.append((mavlink.MAV_SEVERITY_INFO, 'Connection to ground station lost\t'))
        return said
