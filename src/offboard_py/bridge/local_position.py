"""mavros local_position: ~local_position/pose and ~local_position/velocity_local (ENU).

Position and linear velocity from LOCAL_POSITION_NED (NED->ENU); orientation and angular
velocity from the bridge's attitude cache (the latest ATTITUDE_QUATERNION, identity and
zero until one arrives).
"""

from geometry_msgs.msg import PoseStamped, TwistStamped

from offboard_py import frames


class LocalPosition:
    def __init__(self, bridge):
        self.bridge = bridge
        self.frame_id = bridge.cfg['local_position/frame_id']
        self.pose_pub = bridge.publisher('~local_position/pose', PoseStamped)
        self.velocity_pub = bridge.publisher('~local_position/velocity_local', TwistStamped)
        bridge.on('LOCAL_POSITION_NED', self._on_local_position)

    def _on_local_position(self, pos):
        # non-latched topics: build nothing for a topic nobody listens to
        stamp = self.bridge.fcu_stamp_ms(pos.time_boot_ms)
        attitude = self.bridge.attitude
        if self.pose_pub.get_num_connections():
            pose = PoseStamped()
            pose.header.stamp, pose.header.frame_id = stamp, self.frame_id
            p = pose.pose.position
            p.x, p.y, p.z = frames.ned_to_enu(pos.x, pos.y, pos.z)
            q = pose.pose.orientation
            q.x, q.y, q.z, q.w = attitude.orientation_enu
            self.pose_pub.publish(pose)
        if self.velocity_pub.get_num_connections():
            twist = TwistStamped()
            twist.header.stamp, twist.header.frame_id = stamp, self.frame_id
            lin, ang = twist.twist.linear, twist.twist.angular
            lin.x, lin.y, lin.z = frames.ned_to_enu(pos.vx, pos.vy, pos.vz)
            ang.x, ang.y, ang.z = attitude.angular_velocity_enu
            self.velocity_pub.publish(twist)
