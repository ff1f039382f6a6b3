"""mavros imu: the IMU in ROS frames (FLU body), frame ~imu/frame_id (base_link).

- ~imu/data (sensor_msgs/Imu): orientation and angular velocity from the bridge's attitude
  cache, linear acceleration from the latest HIGHRES_IMU that carried one; on every
  ATTITUDE_QUATERNION while subscribed (both kept as they come, decoded when read, so the first
  imu/data a new subscriber gets is now's, as with mavros, which decodes every one);
- from each HIGHRES_IMU, as its fields_updated bits say what is fresh (mavros 1.21's imu plugin):
  ~imu/data_raw when the accelerometer or gyro is (Imu without orientation: orientation_covariance[0]
  is -1), ~imu/mag when the magnetometer is (MagneticField, tesla), ~imu/static_pressure when the
  absolute pressure is, ~imu/diff_pressure when the differential pressure is (FluidPressure, in the
  message's hPa, unconverted, as mavros 1.21 publishes them from HIGHRES_IMU), ~imu/temperature_imu
  when the temperature is (Temperature, deg C). PX4 SITL (SIH) marks its magnetometer fresh about 14
  times a second and its barometer 10 times, in a 50 Hz HIGHRES_IMU, so those topics run at those rates.
- Covariances as mavros's: diagonals of ~imu/linear_acceleration_stdev, ~imu/angular_velocity_stdev,
  ~imu/orientation_stdev and ~imu/magnetic_stdev squared (px4_config.yaml's 0.0003, 0.02 degrees, 1.0
  and 0), element 0 -1 where a deviation is 0 (unknown), and imu/data's linear acceleration's -1
  until a HIGHRES_IMU has carried one. ~imu/temperature_baro is advertised as mavros does; it publishes
  from SCALED_PRESSURE only while no HIGHRES_IMU comes, which PX4 never leaves it.
"""

from sensor_msgs.msg import FluidPressure, Imu as ImuMsg, MagneticField, Temperature

from offboard_py import frames, wire
from offboard_py.dialect import (HIGHRES_IMU_UPDATED_ABS_PRESSURE as ABS_PRESSURE,
                                 HIGHRES_IMU_UPDATED_ACCEL_GYRO as ACCEL_GYRO,
                                 HIGHRES_IMU_UPDATED_DIFF_PRESSURE as DIFF_PRESSURE, HIGHRES_IMU_UPDATED_MAG as MAG,
                                 HIGHRES_IMU_UPDATED_TEMPERATURE as TEMPERATURE)

GAUSS_TO_TESLA = 1e-4


def covariance(stdev):
    """mavros's 3x3 covariance of a standard deviation, row-major: stdev^2 on the diagonal, or element 0
    -1 (unknown) when it is 0."""
    if not stdev:
        return (-1.0,) + (0.0,) * 8
    v = stdev * stdev
    return (v, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, v)


class Imu:
    def __init__(self, bridge):
        self.bridge = bridge
        cfg = bridge.cfg  # read and checked by config.read_config
        self.frame_id = cfg['imu/frame_id']
        self.linear_cov = covariance(cfg['imu/linear_acceleration_stdev'])
        self.angular_cov = covariance(cfg['imu/angular_velocity_stdev'])
        self.orientation_cov = covariance(cfg['imu/orientation_stdev'])
        self.magnetic_cov = covariance(cfg['imu/magnetic_stdev'])
        self.unknown_cov = covariance(0.0)
        self._accel_flu = None  # none yet: imu/data's linear_acceleration_covariance[0] is -1
        self._imu_frame = None  # the latest HIGHRES_IMU, decoded when its acceleration is read
        self.pub = bridge.publisher('~imu/data', ImuMsg)
        self.raw_pub = bridge.publisher('~imu/data_raw', ImuMsg)
        self.mag_pub = bridge.publisher('~imu/mag', MagneticField)
        self.pressure_pub = bridge.publisher('~imu/static_pressure', FluidPressure)
        self.diff_pressure_pub = bridge.publisher('~imu/diff_pressure', FluidPressure)
        self.temperature_pub = bridge.publisher('~imu/temperature_imu', Temperature)
        self.temperature_baro_pub = bridge.publisher('~imu/temperature_baro', Temperature)
        self.raw_listened = bridge.listened(self.raw_pub, self.mag_pub, self.pressure_pub, self.diff_pressure_pub,
                                            self.temperature_pub)
        # every HIGHRES_IMU kept: imu/data's acceleration must be now's from its subscriber's first
        # message on (a subscriber such as rospy.wait_for_message takes the first one)
        bridge.on_raw('HIGHRES_IMU', self._keep_imu)
        bridge.on('HIGHRES_IMU', self._on_highres_imu, needed=self.raw_listened)
        bridge.on('ATTITUDE_QUATERNION', self._on_attitude, needed=bridge.listened(self.pub))

    def _keep_imu(self, frame):
        self._imu_frame = frame

    @property
    def accel_flu(self):
        """The acceleration of the latest HIGHRES_IMU that carried one, FLU (m/s^2); None before any."""
        if self._imu_frame is not None:
            self._take_accel(wire.decode_checked(self._imu_frame))
        return self._accel_flu

    def _take_accel(self, imu):
        self._imu_frame = None
        if imu.fields_updated & ACCEL_GYRO:
            self._accel_flu = frames.frd_to_flu(imu.xacc, imu.yacc, imu.zacc)

    def _on_highres_imu(self, imu):
        self._take_accel(imu)  # this message's: already decoded
        if not self.raw_listened():
            return
        fresh = imu.fields_updated
        stamp = self.bridge.fcu_stamp_us(imu.time_usec)
        if fresh & ACCEL_GYRO:
            raw = ImuMsg()
            raw.header.stamp, raw.header.frame_id = stamp, self.frame_id
            raw.orientation_covariance = self.unknown_cov  # no orientation in this message
            raw.angular_velocity_covariance, raw.linear_acceleration_covariance = self.angular_cov, self.linear_cov
            w, a = raw.angular_velocity, raw.linear_acceleration
            w.x, w.y, w.z = frames.frd_to_flu(imu.xgyro, imu.ygyro, imu.zgyro)
            a.x, a.y, a.z = self._accel_flu
            self.raw_pub.publish(raw)
        if fresh & MAG:
            mag = MagneticField()
            mag.header.stamp, mag.header.frame_id = stamp, self.frame_id
            m = mag.magnetic_field
            m.x, m.y, m.z = (c * GAUSS_TO_TESLA for c in frames.frd_to_flu(imu.xmag, imu.ymag, imu.zmag))
            mag.magnetic_field_covariance = self.magnetic_cov
            self.mag_pub.publish(mag)
        for bit, publisher, value in ((ABS_PRESSURE, self.pressure_pub, imu.abs_pressure),
                                      (DIFF_PRESSURE, self.diff_pressure_pub, imu.diff_pressure)):
            if fresh & bit:
                pressure = FluidPressure(fluid_pressure=value)  # hPa, as mavros 1.21 leaves it
                pressure.header.stamp, pressure.header.frame_id = stamp, self.frame_id
                publisher.publish(pressure)
        if fresh & TEMPERATURE:
            temperature = Temperature(temperature=imu.temperature)
            temperature.header.stamp, temperature.header.frame_id = stamp, self.frame_id
            self.temperature_pub.publish(temperature)

    def _on_attitude(self, att):
        # the bridge's cache has already taken this message (its handler runs before any plugin's)
        if not self.pub.get_num_connections():
            return
        attitude = self.bridge.attitude
        msg = ImuMsg()
        msg.header.stamp, msg.header.frame_id = self.bridge.fcu_stamp_ms(att.time_boot_ms), self.frame_id
        q = msg.orientation
        q.x, q.y, q.z, q.w = attitude.orientation_enu
        w = msg.angular_velocity
        w.x, w.y, w.z = attitude.angular_velocity_flu
        msg.orientation_covariance, msg.angular_velocity_covariance = self.orientation_cov, self.angular_cov
        accel = self.accel_flu
        if accel is None:
            msg.linear_acceleration_covariance = (-1.0,) + self.linear_cov[1:]  # none received yet
        else:
            a = msg.linear_acceleration
            a.x, a.y, a.z = accel
            msg.linear_acceleration_covariance = self.linear_cov
        self.pub.publish(msg)
