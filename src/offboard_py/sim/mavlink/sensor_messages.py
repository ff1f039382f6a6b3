"""The simulated PX4's sensor messages as PX4's streams fill them (src/modules/mavlink/streams/GPS_RAW_INT.hpp,
HIGHRES_IMU.hpp, SCALED_PRESSURE.hpp, DISTANCE_SENSOR.hpp, ESTIMATOR_STATUS.hpp, VIBRATION.hpp,
RC_CHANNELS.hpp): a part of sim.mavlink.messages.TelemetryBuilder, which gives them its time base and the
Status's shared values (_global, _course, _amsl)."""

import math

from offboard_py import dialect
from offboard_py.dialect import mavlink
from offboard_py.sim.sensors import pressure_hpa, temperature_c

GPS_SATELLITES, GPS_EPH, GPS_EPV = 10, 70, 110  # PX4 SITL's simulated GPS
GPS_H_ACC_MM, GPS_V_ACC_MM, GPS_VEL_ACC_MM_S = 500, 800, 200
RANGEFINDER_MIN_CM, RANGEFINDER_MAX_CM = 10, 4000
RC_CHANNEL_COUNT, RC_STICKS_US, RC_SWITCH_LOW_US, RC_UNUSED = 8, [1500] * 4, 1000, 0xFFFF
RC_RSSI = 254  # full signal (255 would be "unknown")
# PX4 SITL (SIH) as recorded (bench/data/px4-hover-replay.json.xz): HIGHRES_IMU.temperature 15.0 deg C
# throughout, SCALED_PRESSURE.temperature the ISA's at the barometer's altitude (1181 cdeg at 489 m)
IMU_TEMPERATURE_C = 15.0
# HIGHRES_IMU.fields_updated as PX4 SITL (SIH) sets it: accelerometer and gyro fresh in every message,
# the magnetometer (0x1C0) in 14.15 a second and the barometer (abs_pressure, pressure_alt, temperature:
# 0x1A00) in 9.88, never diff_pressure: 887 of 1553 messages 0x3F, 356 0x1FF, 222 0x1A3F and 88 0x1BFF in
# the recorded 31.37 s hover (bench/data/px4-hover-replay.json.xz, from reference/conversations/
# takeoff-mavros-px4). Between its samples a sensor's fields hold their last value, as PX4 sends them.
HIGHRES_ACCEL_GYRO, HIGHRES_MAG = dialect.HIGHRES_IMU_UPDATED_ACCEL_GYRO, dialect.HIGHRES_IMU_UPDATED_MAG
HIGHRES_BARO = (dialect.HIGHRES_IMU_UPDATED_ABS_PRESSURE | dialect.HIGHRES_IMU_UPDATED_PRESSURE_ALT
                | dialect.HIGHRES_IMU_UPDATED_TEMPERATURE)
MAG_RATE_HZ, BARO_RATE_HZ = 14.15, 9.88
UINT16_UNKNOWN = 0xFFFF


def _next_sample_s(due_s, now_s, rate_hz):
    """When a sensor sampling at rate_hz, sampled now for its sample due at due_s, is due next: one period
    on from due_s (so the rate holds on a 50 Hz message), or from now after a pause (no burst to catch up)."""
    next_s = due_s + 1.0 / rate_hz
    return next_s if next_s > now_s else now_s + 1.0 / rate_hz


class SensorMessages:
    """GPS_RAW_INT, HIGHRES_IMU, SCALED_PRESSURE, DISTANCE_SENSOR, ESTIMATOR_STATUS, VIBRATION and RC_CHANNELS."""

    def _init_sensors(self, boot_s):
        self._mag = self._baro = None  # HIGHRES_IMU's held magnetometer and barometer fields
        self._mag_due_s = self._baro_due_s = boot_s  # when each sensor's next sample is due

    def _gps_raw_int(self, st, now_s):
        lat, lon, alt = self._global(st)
        speed, course = self._course(st)
        cog = UINT16_UNKNOWN if course is None else int(round(math.degrees(course) * 100.0)) % 36000
        return self.mav.gps_raw_int_encode(
            self.time_usec(now_s), mavlink.GPS_FIX_TYPE_3D_FIX, lat, lon, alt, GPS_EPH, GPS_EPV,
            int(round(speed * 100)), cog, GPS_SATELLITES, alt, GPS_H_ACC_MM, GPS_V_ACC_MM, GPS_VEL_ACC_MM_S, 0, 0)

    def _highres_imu(self, st, now_s):
        ax, ay, az = st.specific_force
        fresh = HIGHRES_ACCEL_GYRO
        if self._mag is None or now_s >= self._mag_due_s:
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            mag_n, mag_d = 0.21, 0.43  # gauss, roughly central Europe
            self._mag = (c * mag_n, -s * mag_n, mag_d)
            self._mag_due_s = _next_sample_s(self._mag_due_s, now_s, MAG_RATE_HZ)
            fresh |= HIGHRES_MAG
        if self._baro is None or now_s >= self._baro_due_s:
            alt = self._amsl(st)
            self._baro = (pressure_hpa(alt), alt)
            self._baro_due_s = _next_sample_s(self._baro_due_s, now_s, BARO_RATE_HZ)
            fresh |= HIGHRES_BARO
        pressure, alt = self._baro
        return self.mav.highres_imu_encode(self.time_usec(now_s), ax, ay, az, *st.gyro, *self._mag,
                                           pressure, 0.0, alt, IMU_TEMPERATURE_C, fresh)

    def _scaled_pressure(self, st, now_s):
        alt = self._amsl(st)
        return self.mav.scaled_pressure_encode(self.time_boot_ms(now_s), pressure_hpa(alt), 0.0,
                                               int(round(temperature_c(alt) * 100)))

    def _distance_sensor(self, st, now_s):
        w, x, y, z = st.attitude
        cos_tilt = max(0.1, 1.0 - 2.0 * (x * x + y * y))  # a downward rangefinder sees the slant range
        distance_cm = int(round(st.height / cos_tilt * 100))
        distance_cm = max(RANGEFINDER_MIN_CM, min(RANGEFINDER_MAX_CM, distance_cm))
        return self.mav.distance_sensor_encode(self.time_boot_ms(now_s), RANGEFINDER_MIN_CM, RANGEFINDER_MAX_CM,
                                               distance_cm, mavlink.MAV_DISTANCE_SENSOR_LASER, 0,
                                               mavlink.MAV_SENSOR_ROTATION_PITCH_270, 1)

    def _estimator_status(self, st, now_s):
        return self.mav.estimator_status_encode(self.time_usec(now_s), st.estimator_flags, 0.05, 0.05, 0.05, 0.05,
                                                0.0, 0.0, GPS_H_ACC_MM / 1000.0, GPS_V_ACC_MM / 1000.0)

    def _vibration(self, st, now_s):
        return self.mav.vibration_encode(self.time_usec(now_s), 0.01, 0.01, 0.01, 0, 0, 0)

    def _rc_channels(self, st, now_s):
        if not st.rc:  # PX4 sends RC_CHANNELS only while an RC input updates
            return None
        # the simulated transmitter: sticks centred (throttle too: PX4's position modes hold), switches low
        channels = RC_STICKS_US + [RC_SWITCH_LOW_US] * (RC_CHANNEL_COUNT - len(RC_STICKS_US))
        channels += [RC_UNUSED] * (18 - RC_CHANNEL_COUNT)
        return self.mav.rc_channels_encode(self.time_boot_ms(now_s), RC_CHANNEL_COUNT, *channels, RC_RSSI)
