"""mavros's /diagnostics: one DiagnosticArray a second, a status per part ("mavros: <name>").

The statuses come from the plugins through Bridge.diagnostic(name, status): the FCU
connection (packets received, dropped by sequence number, parse errors), the heartbeat,
GPS, time sync and battery, with mavros's names and messages ("GPS: No satellites" when
there is no fix, as real mavros says without GPS_RAW_INT). Hardware id: the FCU URL.
"""

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

PERIOD_S = 1.0


class Diagnostics:
    def __init__(self, bridge):
        self.bridge = bridge
        self.hardware_id = bridge.cfg['fcu_url']
        self.pub = bridge.publisher('/diagnostics', DiagnosticArray)
        bridge.every(PERIOD_S, self._publish)

    def _publish(self, _now_s):
        if not self.pub.get_num_connections():
            return
        array = DiagnosticArray()
        array.header.stamp = self.bridge.now()
        for name, status in self.bridge.diagnostics:
            try:
                level, message, values = status()
            except Exception:  # a plugin bug must not take the others' statuses down
                rospy.logerr('diagnostics: status %r failed', name, exc_info=True)
                continue
            array.status.append(DiagnosticStatus(level=level, name='mavros: ' + name, message=message,
                                                 hardware_id=self.hardware_id,
                                                 values=[KeyValue(key=k, value=str(v)) for k, v in values]))
        self.pub.publish(array)
