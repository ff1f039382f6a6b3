"""mavros sys_status's status texts: ~statustext/recv, ~statustext/send, and the FCU's texts in the log.

- Each STATUSTEXT from the FCU is logged as mavros does ("FCU: <text>", at the level of its
  severity) and published on ~statustext/recv (mavros_msgs/StatusText).
- A StatusText on ~statustext/send goes to the FCU as STATUSTEXT; a text over MAVLink's 50
  characters or not ASCII is refused and logged, naming it.
"""

import rospy
from mavros_msgs.msg import StatusText

TEXT_MAX = 50


def _log_for(severity):
    if severity <= StatusText.ERROR:
        return rospy.logerr
    if severity == StatusText.WARNING:
        return rospy.logwarn
    if severity == StatusText.DEBUG:
        return rospy.logdebug
    return rospy.loginfo


class StatusTexts:
    def __init__(self, bridge):
        self.bridge = bridge
        self.pub = bridge.publisher('~statustext/recv', StatusText)
        self.sub = bridge.subscriber('~statustext/send', StatusText, self._send)
        bridge.on('STATUSTEXT', self._on_text)

    def _on_text(self, msg):
        _log_for(msg.severity)('FCU: %s', msg.text)
        if self.pub.get_num_connections():
            out = StatusText(severity=msg.severity, text=msg.text)
            out.header.stamp = self.bridge.now()
            self.pub.publish(out)

    def _send(self, msg):
        if len(msg.text) > TEXT_MAX or not msg.text.isascii():
            rospy.logerr('STATUSTEXT: %r not sent: at most %d ASCII characters', msg.text, TEXT_MAX)
            return
        b = self.bridge
        b.send(b.mav.statustext_encode(msg.severity, msg.text.encode()))
