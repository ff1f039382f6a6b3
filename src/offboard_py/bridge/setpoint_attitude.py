"""mavros setpoint_attitude: a body-rate or an attitude setpoint, each with ~setpoint_attitude/thrust
(mavros_msgs/Thrust), out as SET_ATTITUDE_TARGET.

Which one is mavros's parameter ~setpoint_attitude/use_quaternion, false in px4_config.yaml:
- false: ~setpoint_attitude/cmd_vel (TwistStamped), its angular velocity as body rates, the
  attitude ignored (type_mask ATTITUDE_IGNORE, quaternion identity). mavros turns those rates with
  its ENU <-> NED swap (transform_frame_ned_enu: x and y swapped, z negated), not FLU -> FRD, and so
  does the bridge: what mavros sends is what a user of it has tuned against.
- true: ~setpoint_attitude/attitude (PoseStamped, ENU/FLU), the rates ignored; the orientation is the
  rotation mavros's Eigen takes from it (frames.pose_rotation).
A thrust outside 0..1 (-1..1 with ~setpoint_attitude/reverse_thrust) is not sent, as mavros's
is_normalized refuses it.

mavros pairs the setpoint and the thrust by time stamp (message_filters, approximate time). Here each
setpoint goes out with the latest thrust whose stamp is within PAIR_WINDOW_S of it; a setpoint
without such a thrust waits for the next one, and is logged (throttled).
"""

import math

from geometry_msgs.msg import PoseStamped, TwistStamped
from mavros_msgs.msg import AttitudeTarget, Thrust

from offboard_py import frames

PAIR_WINDOW_S = 0.5
IGNORE_RATES = AttitudeTarget.IGNORE_ROLL_RATE | AttitudeTarget.IGNORE_PITCH_RATE | AttitudeTarget.IGNORE_YAW_RATE


class SetpointAttitude:
    def __init__(self, bridge):
        self.bridge = bridge
        self.thrust = None  # the latest Thrust
        self.reverse_thrust = bridge.cfg['setpoint_attitude/reverse_thrust']
        if bridge.cfg['setpoint_attitude/use_quaternion']:
            setpoint = bridge.subscriber('~setpoint_attitude/attitude', PoseStamped, self._on_attitude)
        else:
            setpoint = bridge.subscriber('~setpoint_attitude/cmd_vel', TwistStamped, self._on_cmd_vel)
        self.subs = [setpoint, bridge.subscriber('~setpoint_attitude/thrust', Thrust, self._on_thrust)]

    def _setpoint_plugin(self):
        return next(p for p in self.bridge.plugins if hasattr(p, 'send_attitude_target'))

    def _on_thrust(self, msg):
        self.thrust = msg

    def _paired_thrust(self, topic, stamp):
        """The thrust to send with a setpoint stamped `stamp`, or None (logged)."""
        thrust, plugin = self.thrust, self._setpoint_plugin()
        if thrust is None or abs((stamp - thrust.header.stamp).to_sec()) > PAIR_WINDOW_S:
            plugin.reject(topic, 'no setpoint_attitude/thrust within %.1f s of it' % PAIR_WINDOW_S)
            return None
        low = -1.0 if self.reverse_thrust else 0.0
        if not low <= thrust.thrust <= 1.0 or math.isnan(thrust.thrust):
            plugin.reject('setpoint_attitude/thrust', 'thrust %r outside %g..1' % (thrust.thrust, low))
            return None
        return thrust.thrust

    def _on_attitude(self, msg):
        thrust = self._paired_thrust('setpoint_attitude/attitude', msg.header.stamp)
        if thrust is None:
            return
        q = msg.pose.orientation
        self._setpoint_plugin().send_attitude_target('setpoint_attitude/attitude', msg.header.stamp, IGNORE_RATES,
                                                     frames.pose_rotation((q.x, q.y, q.z, q.w)), (0.0, 0.0, 0.0),
                                                     thrust)

    def _on_cmd_vel(self, msg):
        thrust = self._paired_thrust('setpoint_attitude/cmd_vel', msg.header.stamp)
        if thrust is None:
            return
        w = msg.twist.angular
        self._setpoint_plugin().send_attitude_target_ned(
            'setpoint_attitude/cmd_vel', msg.header.stamp, AttitudeTarget.IGNORE_ATTITUDE, (0.0, 0.0, 0.0, 1.0),
            frames.enu_to_ned(w.x, w.y, w.z), thrust)
