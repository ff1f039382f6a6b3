"""mavros local_position: the local position in ROS frames (ENU world, FLU body), frame map.

From each LOCAL_POSITION_NED, with orientation and rates from the bridge's attitude cache
(the latest ATTITUDE_QUATERNION; identity and zero until one arrives):
- ~local_position/pose (PoseStamped) and ~local_position/velocity_local (TwistStamped, ENU);
- ~local_position/velocity_body (TwistStamped, FLU) and ~local_position/odom
  (nav_msgs/Odometry, child base_link, twist in the body frame, as mavros 1.x);
- with ~local_position/tf/send (false by default, as mavros's px4_config), the transform
  map -> base_link on /tf (frame names from ~local_position/tf/frame_id, child_frame_id).
"""

from geometry_msgs.msg import PoseStamped, TransformStamped, TwistStamped
from nav_msgs.msg import Odometry
from tf2_msgs.msg import TFMessage

from offboard_py import frames


class LocalPosition:
    def __init__(self, bridge):
        self.bridge = bridge
        cfg = bridge.cfg
        self.frame_id = cfg['local_position/frame_id']
        self.tf_send = cfg['local_position/tf/send']
        self.tf_frame_id, self.tf_child_frame_id = cfg['local_position/tf/frame_id'], cfg['local_position/tf/child_frame_id']
        self.pose_pub = bridge.publisher('~local_position/pose', PoseStamped)
        self.velocity_pub = bridge.publisher('~local_position/velocity_local', TwistStamped)
        self.velocity_body_pub = bridge.publisher('~local_position/velocity_body', TwistStamped)
        self.odom_pub = bridge.publisher('~local_position/odom', Odometry)
        self.tf_pub = bridge.publisher('/tf', TFMessage, queue_size=100) if self.tf_send else None
        # non-latched topics: nothing is decoded or built for topics nobody listens to (/tf, when
        # sent, always has its broadcast)
        pubs = (self.pose_pub, self.velocity_pub, self.velocity_body_pub, self.odom_pub)
        bridge.on('LOCAL_POSITION_NED', self._on_local_position,
                  needed=None if self.tf_send else bridge.listened(*pubs))

    def _on_local_position(self, pos):
        stamp = self.bridge.fcu_stamp_ms(pos.time_boot_ms)
        attitude = self.bridge.attitude
        position = frames.ned_to_enu(pos.x, pos.y, pos.z)
        velocity = frames.ned_to_enu(pos.vx, pos.vy, pos.vz)
        if self.pose_pub.get_num_connections():
            pose = PoseStamped()
            pose.header.stamp, pose.header.frame_id = stamp, self.frame_id
            p = pose.pose.position
            p.x, p.y, p.z = position
            q = pose.pose.orientation
            q.x, q.y, q.z, q.w = attitude.orientation_enu
            self.pose_pub.publish(pose)
        if self.velocity_pub.get_num_connections():
            twist = TwistStamped()
            # the child frame, though the vector is in the map's axes: as mavros 1.21 stamps it
            twist.header.stamp, twist.header.frame_id = stamp, self.tf_child_frame_id
            lin, ang = twist.twist.linear, twist.twist.angular
            lin.x, lin.y, lin.z = velocity
            ang.x, ang.y, ang.z = attitude.angular_velocity_enu
            self.velocity_pub.publish(twist)
        body = None
        if self.velocity_body_pub.get_num_connections() or self.odom_pub.get_num_connections():
            body = frames.rotate(frames.quaternion_conjugate(attitude.orientation_enu), velocity)
        if self.velocity_body_pub.get_num_connections():
            twist = TwistStamped()
            twist.header.stamp, twist.header.frame_id = stamp, self.tf_child_frame_id
            lin, ang = twist.twist.linear, twist.twist.angular
            lin.x, lin.y, lin.z = body
            ang.x, ang.y, ang.z = attitude.angular_velocity_flu
            self.velocity_body_pub.publish(twist)
        if self.odom_pub.get_num_connections():
            odom = Odometry()
            odom.header.stamp, odom.header.frame_id, odom.child_frame_id = stamp, self.frame_id, self.tf_child_frame_id
            p, q = odom.pose.pose.position, odom.pose.pose.orientation
            p.x, p.y, p.z = position
            q.x, q.y, q.z, q.w = attitude.orientation_enu
            lin, ang = odom.twist.twist.linear, odom.twist.twist.angular
            lin.x, lin.y, lin.z = body
            ang.x, ang.y, ang.z = attitude.angular_velocity_flu
            self.odom_pub.publish(odom)
        if self.tf_pub is not None:
            transform = TransformStamped()
            transform.header.stamp, transform.header.frame_id = stamp, self.tf_frame_id
            transform.child_frame_id = self.tf_child_frame_id
            t, r = transform.transform.translation, transform.transform.rotation
            t.x, t.y, t.z = position
            r.x, r.y, r.z, r.w = attitude.orientation_enu
            self.tf_pub.publish(TFMessage(transforms=[transform]))
