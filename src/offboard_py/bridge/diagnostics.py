"""mavros's /diagnostics: a DiagnosticArray every 1.0 or 1.5 s as mavros's updater sends it, a status per
part named after the node as diagnostic_updater names it ("mavros: <name>", "uav3/mavros: <name>").

The statuses come from the plugins through Bridge.diagnostic(name, status): the FCU
connection (packets received, dropped by sequence number, parse errors), the heartbeat,
GPS, the system's sensors, time sync and battery, with mavros's names, order and messages ("GPS: No satellites" when
there is no fix, as real mavros says without GPS_RAW_INT; the heartbeat's and time sync's
"Normal" or "No events recorded." from their events over the last ten periods, as mavros's
HeartbeatStatus and TimeSyncStatus say it). Hardware id: the FCU URL.
"""

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

PERIOD_S = 1.0  # diagnostic_updater's period: a status at most this often
CHECK_S = 0.5   # how often mavros's timer asks the updater: a status every 1.0 or 1.5 s (0.75 a second measured)
# the order real mavros 1.21 gives them in (its plugins load alphabetically: global_position, sys_status, sys_time)
ORDER = ('FCU connection', 'GPS', 'Heartbeat', 'System', 'Battery', 'Time Sync')
_RANK = {name: i for i, name in enumerate(ORDER)}


class EventWindow:
    """The event frequency of mavros's Heartbeat and Time Sync statuses (after diagnostic_updater's
    FrequencyStatus): tick() counts an event; each run(), once a diagnostics period, compares the count
    with the one window_size runs before (or with the last clear()) and says how it stands."""

    def __init__(self, clock, min_hz, max_hz, tolerance=0.1, window_size=10):
        self.clock = clock
        self.min_hz, self.max_hz, self.tolerance = min_hz, max_hz, tolerance
        self.window_size = window_size
        self.clear()

    def clear(self):
        now_s = self.clock()
        self.count = 0
        self.times_s = [now_s] * self.window_size
        self.counts = [0] * self.window_size
        self.index = 0

    def tick(self):
        self.count += 1

    def run(self):
        """(level, message, frequency in Hz) over the window, moving it on by one run."""
        now_s, i = self.clock(), self.index
        events, window_s = self.count - self.counts[i], now_s - self.times_s[i]
        frequency = events / window_s if window_s > 0 else (float('inf') if events else 0.0)
        self.counts[i], self.times_s[i] = self.count, now_s
        self.index = (i + 1) % self.window_size
        if events == 0:
            return 2, 'No events recorded.', frequency
        if frequency < self.min_hz * (1.0 - self.tolerance):
            return 1, 'Frequency too low.', frequency
        if frequency > self.max_hz * (1.0 + self.tolerance):
            return 1, 'Frequency too high.', frequency
        return 0, 'Normal', frequency


class Diagnostics:
    def __init__(self, bridge):
        self.bridge = bridge
        self.hardware_id = bridge.cfg['fcu_url']
        # diagnostic_updater names a status after its node: "mavros: GPS", "uav3/mavros: GPS" in a fleet
        self.prefix = bridge.node_name()[1:] + ': '
        self.pub = bridge.publisher('/diagnostics', DiagnosticArray)
        self.next_s = None
        bridge.every(CHECK_S, self._publish)

    def _publish(self, now_s):
        """As mavros's updater: asked every CHECK_S, it runs once PERIOD_S has passed since its last
        run, subscribed or not (a status may keep a window of its runs: EventWindow)."""
        if self.next_s is not None and now_s < self.next_s:
            return
        self.next_s = now_s + PERIOD_S
        statuses = []
        for name, status in sorted(self.bridge.diagnostics, key=lambda item: _RANK.get(item[0], len(ORDER))):
            try:
                statuses.append((name, status()))
            except Exception:  # a plugin bug must not take the others' statuses down
                rospy.logerr('diagnostics: status %r failed', name, exc_info=True)
        if not self.pub.get_num_connections():
            return
        array = DiagnosticArray()
        array.header.stamp = self.bridge.now()
        for name, (level, message, values) in statuses:
            array.status.append(DiagnosticStatus(level=level, name=self.prefix + name, message=message,
                                                 hardware_id=self.hardware_id,
                                                 values=[KeyValue(key=k, value=str(v)) for k, v in values]))
        self.pub.publish(array)
