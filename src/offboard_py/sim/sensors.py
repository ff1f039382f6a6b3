"""The simulated PX4's inertial sensors as SIH makes them and PX4's sensor pipeline passes them on.

SIH adds white Gaussian noise to the true body rates and specific force on every step
(simulator_sih: gyro standard deviations 0.14, 0.07, 0.03 rad/s, accelerometer 0.5, 1.7, 1.4 m/s^2,
per axis x, y, z), which is why in hover the roll axis reads about twice as lively as pitch
(reference/px4-sitl-measured.md, "Turn 3 recordings", section 2). What reaches MAVLink is that noise
after PX4's filtering: HIGHRES_IMU's gyro carries about 0.82 of SIH's standard deviation and its
accelerometer about 0.74 (hover: xgyro 0.115-0.118, ygyro 0.056, zgyro 0.024-0.028; xacc 0.36-0.39,
yacc 1.20-1.29, zacc 1.02-1.04), and ATTITUDE's rates (the filtered angular velocity) about 0.85 of
HIGHRES_IMU's on every axis, in hover and on the ground alike (rollspeed 0.099 against xgyro 0.115;
0.0059 against 0.0069 on the ground): a first-order low-pass on the gyro reproduces that ratio.
On the ground, at rest and disarmed, the recorded noise is much smaller and the same on every axis
(gyro 0.0067-0.0076 rad/s, accelerometer 0.070-0.075 m/s^2).

Seeded, as SIH seeds its noise (srand(1234)), so a run repeats exactly; the stream is separate
from the estimator's, so adding or changing sensor noise never changes a flight. Pure: no clock,
no MAVLink. The barometer's atmosphere is the ISA's (pressure_hpa, temperature_c).
"""

import random

# PX4 SITL's SIH noise, 1 sigma per body axis (x, y, z)
SIH_GYRO_SD = (0.14, 0.07, 0.03)     # rad/s
SIH_ACCEL_SD = (0.5, 1.7, 1.4)       # m/s^2
# the fraction of it HIGHRES_IMU shows in hover (section 2: 0.115 / 0.14, 0.056 / 0.07, 0.026 / 0.03;
# 0.375 / 0.5, 1.25 / 1.7, 1.03 / 1.4)
GYRO_PASSED, ACCEL_PASSED = 0.82, 0.74
# at rest on the ground (section 2, "ground" columns): the same on every axis
GROUND_GYRO_SD, GROUND_ACCEL_SD = 0.0070, 0.072
# ATTITUDE's rates: HIGHRES_IMU's gyro through a first-order low-pass whose noise gain
# sqrt(a / (2 - a)) is 0.85 (rollspeed 0.099 / xgyro 0.115 in hover, 0.0059 / 0.0069 on the
# ground) at the simulator's 100 Hz: a = 0.84, a time constant of 1.9 ms
RATE_FILTER_TAU_S = 0.0019


def pressure_hpa(alt_amsl_m):
    """ISA static pressure at an altitude AMSL."""
    return 1013.25 * (1.0 - 2.25577e-5 * alt_amsl_m) ** 5.25588


def temperature_c(alt_amsl_m):
    """ISA temperature at an altitude AMSL (15 deg C at sea level, 6.5 K a kilometre colder)."""
    return 15.0 - 0.0065 * alt_amsl_m


class SihImu:
    """Gyro and accelerometer readings: the truth plus SIH-like noise, and the filtered rates
    ATTITUDE reports. `ideal` reads the truth."""

    def __init__(self, seed=1234, ideal=False):
        self.ideal = ideal
        # a stream of its own (str seeds hash the same in every Python 3 run)
        self._gauss = random.Random('imu-%s' % (seed,)).gauss
        self.gyro = (0.0, 0.0, 0.0)    # rad/s, FRD: HIGHRES_IMU
        self.rates = (0.0, 0.0, 0.0)   # rad/s, FRD: ATTITUDE, ATTITUDE_QUATERNION, ODOMETRY
        self.accel = (0.0, 0.0, -9.80665)  # m/s^2, FRD: HIGHRES_IMU
        self._flight_gyro_sd = tuple(GYRO_PASSED * s for s in SIH_GYRO_SD)
        self._flight_accel_sd = tuple(ACCEL_PASSED * s for s in SIH_ACCEL_SD)

    def step(self, dt, true_rates, specific_force, at_rest):
        """Read the sensors after a model step of dt seconds: true body rates (rad/s) and specific
        force (m/s^2), both FRD; `at_rest` on the ground with the motors off."""
        if self.ideal:
            self.gyro = self.rates = tuple(true_rates)
            self.accel = tuple(specific_force)
            return
        g = self._gauss
        if at_rest:
            gyro_sd = (GROUND_GYRO_SD,) * 3
            accel_sd = (GROUND_ACCEL_SD,) * 3
        else:
            gyro_sd, accel_sd = self._flight_gyro_sd, self._flight_accel_sd
        gyro = (true_rates[0] + g(0.0, gyro_sd[0]), true_rates[1] + g(0.0, gyro_sd[1]),
                true_rates[2] + g(0.0, gyro_sd[2]))
        self.accel = (specific_force[0] + g(0.0, accel_sd[0]), specific_force[1] + g(0.0, accel_sd[1]),
                      specific_force[2] + g(0.0, accel_sd[2]))
        a = dt / (dt + RATE_FILTER_TAU_S) if dt > 0.0 else 1.0
        r = self.rates
        self.rates = (r[0] + a * (gyro[0] - r[0]), r[1] + a * (gyro[1] - r[1]), r[2] + a * (gyro[2] - r[2]))
        self.gyro = gyro

