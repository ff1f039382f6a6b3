"""mavros imu: ~imu/data (sensor_msgs/Imu, ENU/FLU).

Orientation and angular velocity from ATTITUDE_QUATERNION, linear acceleration from the
latest HIGHRES_IMU; published on every ATTITUDE_QUATERNION, frame base_link.
"""

import rospy
from sensor_msgs.msg import Imu as ImuMsg

from offboard_py import frames


class Imu:
    def __init__(self, bridge):
        self.accel_flu = (0.0, 0.0, 0.0)
        self.pub = rospy.Publisher('~imu/data', ImuMsg, queue_size=10)
        bridge.on('HIGHRES_IMU', self._on_highres_imu)
        bridge.on('ATTITUDE_QUATERNION', self._on_attitude)

    def _on_highres_imu(self, imu):
        self.accel_flu = frames.frd_to_flu(imu.xacc, imu.yacc, imu.zacc)

    def _on_attitude(self, att):
        if not self.pub.get_num_connections():
            return
        msg = ImuMsg()
        msg.header.stamp, msg.header.frame_id = rospy.Time.now(), 'base_link'
        q = msg.orientation
        q.x, q.y, q.z, q.w = frames.orientation_ned_to_enu(frames.wxyz_to_xyzw(att.q1, att.q2, att.q3, att.q4))
        w = msg.angular_velocity
        w.x, w.y, w.z = frames.frd_to_flu(att.rollspeed, att.pitchspeed, att.yawspeed)
        a = msg.linear_acceleration
        a.x, a.y, a.z = self.accel_flu
        self.pub.publish(msg)
