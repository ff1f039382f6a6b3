"""mavros imu: ~imu/data (sensor_msgs/Imu, ENU/FLU).

Orientation and angular velocity from the bridge's attitude cache, linear acceleration
from the latest HIGHRES_IMU; published on every ATTITUDE_QUATERNION, frame base_link.
"""

from sensor_msgs.msg import Imu as ImuMsg

from offboard_py import frames


class Imu:
    def __init__(self, bridge):
        self.bridge = bridge
        self.accel_flu = (0.0, 0.0, 0.0)
        self.pub = bridge.publisher('~imu/data', ImuMsg)
        bridge.on('HIGHRES_IMU', self._on_highres_imu)
        bridge.on('ATTITUDE_QUATERNION', self._on_attitude)

    def _on_highres_imu(self, imu):
        self.accel_flu = frames.frd_to_flu(imu.xacc, imu.yacc, imu.zacc)

    def _on_attitude(self, att):
        # the bridge's cache has already taken this message (its handler runs before any plugin's)
        if not self.pub.get_num_connections():
            return
        attitude = self.bridge.attitude
        msg = ImuMsg()
        msg.header.stamp, msg.header.frame_id = self.bridge.fcu_stamp_ms(att.time_boot_ms), 'base_link'
        q = msg.orientation
        q.x, q.y, q.z, q.w = attitude.orientation_enu
        w = msg.angular_velocity
        w.x, w.y, w.z = attitude.angular_velocity_flu
        a = msg.linear_acceleration
        a.x, a.y, a.z = self.accel_flu
        self.pub.publish(msg)
