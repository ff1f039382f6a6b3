"""mavros's /diagnostics: one DiagnosticArray a second, a status per part ("mavros: <name>").

The statuses come from the plugins through Bridge.diagnostic(name, status): the FCU
connection (packets received, dropped by sequence number, parse errors), the heartbeat,
GPS, time sync and battery, with mavros's names and messages ("GPS: No satellites" when
there is no fix, as real mavros says without GPS_RAW_INT; the heartbeat's and time sync's
"Normal" or "No events recorded." from their events over the last ten periods, as mavros's
HeartbeatStatus and TimeSyncStatus say it). Hardware id: the FCU URL.
"""

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

PERIOD_S = 1.0


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
        self.pub = bridge.publisher('/diagnostics', DiagnosticArray)
        bridge.every(PERIOD_S, self._publish)

    def _publish(self, _now_s):
        """Every period, subscribed or not, as mavros's updater runs its tasks: a status may keep a
        window of its runs (EventWindow)."""
        statuses = []
        for name, status in self.bridge.diagnostics:
            try:
                statuses.append((name, status()))
            except Exception:  # a plugin bug must not take the others' statuses down
                rospy.logerr('diagnostics: status %r failed', name, exc_info=True)
        if not self.pub.get_num_connections():
            return
        array = DiagnosticArray()
        array.header.stamp = self.bridge.now()
        for name, (level, message, values) in statuses:
            array.status.append(DiagnosticStatus(level=level, name='mavros: ' + name, message=message,
                                                 hardware_id=self.hardware_id,
                                                 values=[KeyValue(key=k, value=str(v)) for k, v in values]))
        self.pub.publish(array)
