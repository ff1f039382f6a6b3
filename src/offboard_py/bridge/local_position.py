"""mavros local_position: ~local_position/pose and ~local_position/velocity_local (ENU).

Position from LOCAL_POSITION_NED (NED->ENU); orientation from the latest
ATTITUDE_QUATERNION (NED/FRD -> ENU/FLU), the identity until one arrives.
"""

import rospy
from geometry_msgs.msg import PoseStamped, TwistStamped

from offboard_py import frames

IDENTITY = (0.0, 0.0, 0.0, 1.0)


class LocalPosition:
    def __init__(self, bridge):
        self.bridge = bridge
        self.frame_id = bridge.cfg['local_position/frame_id']
        self.orientation_enu = IDENTITY
        self.angular_enu = (0.0, 0.0, 0.0)
        self.pose_pub = rospy.Publisher('~local_position/pose', PoseStamped, queue_size=10)
        self.velocity_pub = rospy.Publisher('~local_position/velocity_local', TwistStamped, queue_size=10)
        bridge.on('ATTITUDE_QUATERNION', self._on_attitude)
        bridge.on('LOCAL_POSITION_NED', self._on_local_position)

    def _on_attitude(self, att):
        q_ned = frames.wxyz_to_xyzw(att.q1, att.q2, att.q3, att.q4)
        self.orientation_enu = frames.orientation_ned_to_enu(q_ned)
        rates_flu = frames.frd_to_flu(att.rollspeed, att.pitchspeed, att.yawspeed)
        self.angular_enu = frames.rotate(self.orientation_enu, rates_flu)

    def _on_local_position(self, pos):
        # non-latched topics: build nothing for a topic nobody listens to
        stamp = rospy.Time.now()
        if self.pose_pub.get_num_connections():
            pose = PoseStamped()
            pose.header.stamp, pose.header.frame_id = stamp, self.frame_id
            p = pose.pose.position
            p.x, p.y, p.z = frames.ned_to_enu(pos.x, pos.y, pos.z)
            q = pose.pose.orientation
            q.x, q.y, q.z, q.w = self.orientation_enu
            self.pose_pub.publish(pose)
        if self.velocity_pub.get_num_connections():
            twist = TwistStamped()
            twist.header.stamp, twist.header.frame_id = stamp, self.frame_id
            lin, ang = twist.twist.linear, twist.twist.angular
            lin.x, lin.y, lin.z = frames.ned_to_enu(pos.vx, pos.vy, pos.vz)
            ang.x, ang.y, ang.z = self.angular_enu
            self.velocity_pub.publish(twist)
