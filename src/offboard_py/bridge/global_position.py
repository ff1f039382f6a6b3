"""mavros global_position: ~global_position/global (NavSatFix) from GLOBAL_POSITION_INT.

Altitude is AMSL as PX4 sends it: real mavros converts to height above the WGS-84
ellipsoid with a geoid model (EGM96), which this bridge does not carry (see README).
"""

from sensor_msgs.msg import NavSatFix, NavSatStatus


class GlobalPosition:
    def __init__(self, bridge):
        self.bridge = bridge
        self.frame_id = bridge.cfg['global_position/frame_id']
        self.pub = bridge.publisher('~global_position/global', NavSatFix)
        bridge.on('GLOBAL_POSITION_INT', self._on_global_position)

    def _on_global_position(self, gp):
        if not self.pub.get_num_connections():
            return  # nobody listens: skip the work (the topic is not latched)
        fix = NavSatFix()
        fix.header.stamp, fix.header.frame_id = self.bridge.fcu_stamp_ms(gp.time_boot_ms), self.frame_id
        fix.status.status, fix.status.service = NavSatStatus.STATUS_FIX, NavSatStatus.SERVICE_GPS
        fix.latitude, fix.longitude, fix.altitude = gp.lat * 1e-7, gp.lon * 1e-7, gp.alt * 1e-3
        fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
        self.pub.publish(fix)
