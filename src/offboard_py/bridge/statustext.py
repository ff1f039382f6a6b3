"""mavros sys_status's status texts: ~statustext/recv, ~statustext/send, and the FCU's texts in the log.

- Each STATUSTEXT from the FCU is logged as mavros does ("FCU: <text>", at the level of its
  severity) and published on ~statustext/recv (mavros_msgs/StatusText).
- A StatusText on ~statustext/send goes to the FCU as STATUSTEXT, as mavros sends it: the text's
  UTF-8 bytes, cut after MAVLink's 50 (mavros's set_string_z; a character may be cut in two), with
  mavros's warning when the text has 50 bytes or more. Dropping it instead, as the bridge did, lost
  a user's message that mavros delivers.
"""

import rospy
from mavros_msgs.msg import StatusText

TEXT_MAX = 50  # STATUSTEXT.text is char[50]


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
        text = msg.text.encode('utf-8', 'surrogateescape')
        if len(text) >= TEXT_MAX:  # mavros's condition: at 50 nothing is cut, but it warns all the same
            rospy.logwarn('Status text too long: truncating...')
        b = self.bridge
        b.send(b.mav.statustext_encode(msg.severity, text[:TEXT_MAX]))
