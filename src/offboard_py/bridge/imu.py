"""mavros imu: the IMU in ROS frames (FLU body), frame base_link.

- ~imu/data (sensor_msgs/Imu): orientation and angular velocity from the bridge's attitude
  cache, linear acceleration from the latest HIGHRES_IMU; on every ATTITUDE_QUATERNION while
  subscribed (both kept as they come, decoded when read, so the first imu/data a new subscriber
  gets is now's, as with mavros, which decodes every one);
- from each HIGHRES_IMU: ~imu/data_raw (Imu without orientation: orientation_covariance[0]
  is -1, as mavros), ~imu/mag (MagneticField, tesla), ~imu/static_pressure (FluidPressure,
  Pa) and ~imu/temperature_imu (Temperature, deg C).
"""

from sensor_msgs.msg import FluidPressure, Imu as ImuMsg, MagneticField, Temperature

from offboard_py import frames, wire

GAUSS_TO_TESLA = 1e-4
HPA_TO_PA = 100.0


class Imu:
    def __init__(self, bridge):
        self.bridge = bridge
        self._accel_flu = (0.0, 0.0, 0.0)
        self._imu_frame = None  # the latest HIGHRES_IMU, decoded when its acceleration is read
        self.pub = bridge.publisher('~imu/data', ImuMsg)
        self.raw_pub = bridge.publisher('~imu/data_raw', ImuMsg)
        self.mag_pub = bridge.publisher('~imu/mag', MagneticField)
        self.pressure_pub = bridge.publisher('~imu/static_pressure', FluidPressure)
        self.temperature_pub = bridge.publisher('~imu/temperature_imu', Temperature)
        self.raw_listened = bridge.listened(self.raw_pub, self.mag_pub, self.pressure_pub, self.temperature_pub)
        # every HIGHRES_IMU kept: imu/data's acceleration must be now's from its subscriber's first
        # message on (a subscriber such as rospy.wait_for_message takes the first one)
        bridge.on_raw('HIGHRES_IMU', self._keep_imu)
        bridge.on('HIGHRES_IMU', self._on_highres_imu, needed=self.raw_listened)
        bridge.on('ATTITUDE_QUATERNION', self._on_attitude, needed=bridge.listened(self.pub))

    def _keep_imu(self, frame):
        self._imu_frame = frame

    @property
    def accel_flu(self):
        """The latest HIGHRES_IMU's acceleration, FLU (m/s^2)."""
        if self._imu_frame is not None:
            imu = wire.decode_checked(self._imu_frame)
            self._accel_flu = frames.frd_to_flu(imu.xacc, imu.yacc, imu.zacc)
            self._imu_frame = None
        return self._accel_flu

    def _on_highres_imu(self, imu):
        self._accel_flu = frames.frd_to_flu(imu.xacc, imu.yacc, imu.zacc)
        self._imu_frame = None  # this message's: already decoded
        if not self.raw_listened():
            return
        stamp = self.bridge.fcu_stamp_us(imu.time_usec)
        raw = ImuMsg()
        raw.header.stamp, raw.header.frame_id = stamp, 'base_link'
        raw.orientation_covariance[0] = -1.0  # no orientation in this message
        w, a = raw.angular_velocity, raw.linear_acceleration
        w.x, w.y, w.z = frames.frd_to_flu(imu.xgyro, imu.ygyro, imu.zgyro)
        a.x, a.y, a.z = self.accel_flu
        self.raw_pub.publish(raw)
        mag = MagneticField()
        mag.header = raw.header
        m = mag.magnetic_field
        m.x, m.y, m.z = (c * GAUSS_TO_TESLA for c in frames.frd_to_flu(imu.xmag, imu.ymag, imu.zmag))
        self.mag_pub.publish(mag)
        pressure = FluidPressure(fluid_pressure=imu.abs_pressure * HPA_TO_PA)
        pressure.header = raw.header
        self.pressure_pub.publish(pressure)
        temperature = Temperature(temperature=imu.temperature)
        temperature.header = raw.header
        self.temperature_pub.publish(temperature)

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
