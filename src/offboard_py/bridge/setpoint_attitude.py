"""mavros setpoint_attitude: ~setpoint_attitude/attitude (PoseStamped, ENU/FLU) with
~setpoint_attitude/thrust (mavros_msgs/Thrust) out as SET_ATTITUDE_TARGET (body rates ignored).

mavros pairs the two topics by time stamp (message_filters, approximate time). Here each
attitude goes out with the latest thrust whose stamp is within PAIR_WINDOW_S of it; an
attitude without such a thrust waits for the next one, and is logged (throttled). The
orientation is the rotation mavros's Eigen takes from it (frames.pose_rotation).
"""

import math

from geometry_msgs.msg import PoseStamped
from mavros_msgs.msg import AttitudeTarget, Thrust

from offboard_py import frames

PAIR_WINDOW_S = 0.5
IGNORE_RATES = AttitudeTarget.IGNORE_ROLL_RATE | AttitudeTarget.IGNORE_PITCH_RATE | AttitudeTarget.IGNORE_YAW_RATE


class SetpointAttitude:
    def __init__(self, bridge):
        self.bridge = bridge
        self.thrust = None  # the latest Thrust
        self.subs = [bridge.subscriber('~setpoint_attitude/attitude', PoseStamped, self._on_attitude),
                     bridge.subscriber('~setpoint_attitude/thrust', Thrust, self._on_thrust)]

    def _setpoint_plugin(self):
        return next(p for p in self.bridge.plugins if hasattr(p, 'send_attitude_target'))

    def _on_thrust(self, msg):
        self.thrust = msg

    def _on_attitude(self, msg):
        thrust = self.thrust
        plugin = self._setpoint_plugin()
        if thrust is None or abs((msg.header.stamp - thrust.header.stamp).to_sec()) > PAIR_WINDOW_S:
            plugin.reject('setpoint_attitude/attitude', 'no setpoint_attitude/thrust within %.1f s of it'
                           % PAIR_WINDOW_S)
            return
        if not 0.0 <= thrust.thrust <= 1.0 or math.isnan(thrust.thrust):
            plugin.reject('setpoint_attitude/thrust', 'thrust %r outside 0..1' % thrust.thrust)
            return
        q = msg.pose.orientation
        plugin.send_attitude_target('setpoint_attitude/attitude', msg.header.stamp, IGNORE_RATES,
                                    frames.pose_rotation((q.x, q.y, q.z, q.w)), (0.0, 0.0, 0.0), thrust.thrust)
