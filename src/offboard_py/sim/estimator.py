"""What PX4's estimator adds to the simulated truth, as PX4 SITL (SIH) shows it: where the estimate
puts a vehicle resting on the ground after a fresh start, white noise on position and velocity
(quieter at rest, disarmed), and the slow gust that makes the vehicle wander in hover. Seeded: the
same seed gives the same flight; an ideal estimator is silent.

And EKF2's word on its horizontal position when the GPS goes (PX4 SITL with Gazebo Classic, whose
SimulatorMavlink stops the GPS messages on MAV_CMD_INJECT_FAILURE GPS OFF): the position is dead-reckoned,
then invalid once no aiding came for EKF2_NOAID_TOUT (ekf_helper.cpp updateHorizontalDeadReckoningstatus:
local_position_is_valid() is !_horizontal_deadreckon_time_exceeded). Back, the GPS must pass EKF2's checks
for GPS_CHECKS_PASS_S before EKF2 fuses it again. How the estimate drifts meanwhile is not modelled.
"""

import math
import random

# PX4 SITL's local position on the ground after a fresh start (reference/px4-sitl-measured.md, "Turn 3
# recordings", section 7: eight starts): z reads 0.1-0.55 m above the origin and takes a few values
# that repeat, since SIH seeds its noise; a vehicle here takes the start its seed picks (seed 1: start 1)
GROUND_STARTS = ((-0.158, 0.081, -0.179), (0.214, -0.343, -0.097), (-0.122, 0.079, -0.175),
                 (-0.191, 0.095, -0.547), (-0.127, 0.081, -0.174), (0.054, -0.216, -0.507),
                 (0.055, -0.215, -0.507), (0.053, -0.216, -0.507))
# at rest on the ground, disarmed, the estimate is steadier than in flight (section 7: z within 0.01 m over 5 s)
RESTING_NOISE_SCALE = 0.15
# hover wander and estimator noise of PX4 SITL's size (px4-sitl-measured.md: z +-0.1 m, xy up to 0.6 m)
GUST_XY, GUST_Z, GUST_TAU_S = 0.5, 0.25, 4.0   # m/s^2 standard deviation, correlation time
GUST_SMOOTH_S = 2.0                            # s, a first-order low-pass on it
NOISE_POSITION_XY, NOISE_POSITION_Z, NOISE_VELOCITY = 0.02, 0.01, 0.03  # m, m, m/s (1 sigma)
# EKF2's GPS quality checks must pass this long before it fuses a GPS (EKF2 _min_gps_health_time_us, 10 s)
GPS_CHECKS_PASS_S = 10.0


def ground_start(seed):
    """Where PX4 SITL's estimate puts a vehicle resting on the ground after a fresh start
    (local NED, m): one of section 7's starts, picked by the seed."""
    try:
        index = int(seed) - 1
    except (TypeError, ValueError):
        index = sum(ord(c) for c in str(seed))
    return GROUND_STARTS[index % len(GROUND_STARTS)]


class Estimator:
    """What PX4's estimator adds to the truth: white noise on position and velocity, and the gust
    that makes the vehicle wander. Seeded: the same seed gives the same flight. `ideal` is silent."""

    def __init__(self, seed=1, ideal=False):
        self.ideal = ideal
        self.seed = seed
        self.rng = random.Random(seed)
        self._raw_gust = [0.0, 0.0, 0.0]
        self.gust = [0.0, 0.0, 0.0]
        self.gps_off_s = None   # when the GPS messages stopped
        self.gps_on_s = None    # when they came back, after a loss

    def gps_off(self, now_s):
        if self.gps_off_s is None:
            self.gps_off_s, self.gps_on_s = now_s, None

    def gps_on(self, now_s):
        if self.gps_off_s is not None and self.gps_on_s is None:
            self.gps_on_s = now_s

    def position_valid(self, now_s, no_aid_timeout_s):
        """EKF2's horizontal position (local and global) is valid: no GPS loss, or one shorter than
        EKF2_NOAID_TOUT, or a GPS back and fused again."""
        if self.gps_off_s is None:
            return True
        if self.gps_on_s is not None and now_s - self.gps_on_s >= GPS_CHECKS_PASS_S:
            self.gps_off_s = self.gps_on_s = None
            return True
        return now_s - self.gps_off_s <= no_aid_timeout_s

    def step_gust(self, dt):
        if self.ideal:
            return self.gust
        decay = math.exp(-dt / GUST_TAU_S)
        spread = math.sqrt(1.0 - decay * decay)
        g, raw, gust = self.rng.gauss, self._raw_gust, self.gust
        raw[0] = decay * raw[0] + spread * GUST_XY * g(0.0, 1.0)
        raw[1] = decay * raw[1] + spread * GUST_XY * g(0.0, 1.0)
        raw[2] = decay * raw[2] + spread * GUST_Z * g(0.0, 1.0)
        # smoothed: PX4 SITL's wander is slow (the estimate drifting, SIH has no wind), and its
        # body rates in hover are SIH's gyro noise with next to no motion under it (section 2)
        smooth = min(1.0, dt / GUST_SMOOTH_S)
        for i in (0, 1, 2):
            gust[i] += smooth * (raw[i] - gust[i])
        return gust

    def measure(self, position, velocity, resting=False):
        if self.ideal:
            return tuple(position), tuple(velocity)
        g = self.rng.gauss
        k = RESTING_NOISE_SCALE if resting else 1.0
        pos = (position[0] + g(0.0, k * NOISE_POSITION_XY), position[1] + g(0.0, k * NOISE_POSITION_XY),
               position[2] + g(0.0, k * NOISE_POSITION_Z))
        vel = (velocity[0] + g(0.0, k * NOISE_VELOCITY), velocity[1] + g(0.0, k * NOISE_VELOCITY),
               velocity[2] + g(0.0, k * NOISE_VELOCITY))
        return pos, vel
