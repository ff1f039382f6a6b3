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

from offboard_py.dialect import mavlink

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
# ESTIMATOR_STATUS.flags from boot, as both recorded conversations from PX4's start show them (reference/
# px4-sitl-boot-timeline.json; a 1 Hz stream): 164 (vertical only, constant position) first, 229 (attitude
# too) from a message in 1.45-2.36 s of boot, 1023 (horizontal too) from one in 2.46-3.37 s; armed, EKF2
# leaves its constant-position mode (895)
ESTIMATOR_FLAGS_BOOT = (mavlink.ESTIMATOR_VELOCITY_VERT | mavlink.ESTIMATOR_POS_VERT_ABS
                        | mavlink.ESTIMATOR_CONST_POS_MODE)
ESTIMATOR_FLAGS_ATTITUDE = ESTIMATOR_FLAGS_BOOT | mavlink.ESTIMATOR_ATTITUDE | mavlink.ESTIMATOR_POS_VERT_AGL
ESTIMATOR_FLAGS_READY = (ESTIMATOR_FLAGS_ATTITUDE | mavlink.ESTIMATOR_VELOCITY_HORIZ
                         | mavlink.ESTIMATOR_POS_HORIZ_REL | mavlink.ESTIMATOR_POS_HORIZ_ABS
                         | mavlink.ESTIMATOR_PRED_POS_HORIZ_REL | mavlink.ESTIMATOR_PRED_POS_HORIZ_ABS)
ESTIMATOR_FLAGS_FLYING = ESTIMATOR_FLAGS_READY & ~mavlink.ESTIMATOR_CONST_POS_MODE
ESTIMATOR_ATTITUDE_S, ESTIMATOR_HORIZONTAL_S = 2.0, 3.0
# EKF2's velocity errs in flight (reference/px4-sitl-measured.md, "Turn 5 recordings": a user's square flown with
# velocity setpoints and vz 0; traces/px4-sitl-velocity-square-{1,2}.csv): its vertical velocity about 0 while
# the true one was +-0.1 m/s, so the height drifted 2.5 -> 4.3 and 2.45 -> 3.8 m in 33 s, down first for about
# 10 s and up for 15-20 s in both runs. The bias here is a slow oscillation of that size and time scale (its
# phase the seed's), horizontal at half its size; on the ground EKF2 has no bias (LOCAL_POSITION_NED's vz at rest,
# section 7). Position control holds through it: an offset of bias / MPC_Z_P, within the 0.24 m that PX4's 80 s
# hovers wandered (reference/px4-sitl-hover.json).
# It grows over the first VELOCITY_BIAS_ONSET_S of a flight (EKF2 starts each flight from its ground alignment):
# PX4's six recorded OFFBOARD takeoffs reached 1.9 m 5.86-8.51 s after the arm.
VELOCITY_BIAS_MPS = (0.05, 0.05, 0.1)  # north, east, down amplitude
VELOCITY_BIAS_PERIOD_S, VELOCITY_BIAS_ONSET_S = 45.0, 10.0
# At touchdown SIH's ground stops the vehicle in one step, and EKF2's vertical estimate follows late: PX4's
# estimate went on down at about the landing speed for 2-3 s, to 0.7-1.0 m below the ground, and came back
# over 3 s (px4-sitl-auto-trace.csv, the NAV_LAND: 0.97 m at 3.2 s; velocity-square-2: 0.68 m). The lag
# decays with TOUCHDOWN_LAG_S and the height comes back with TOUCHDOWN_RECOVERY_S (baro fusion)
TOUCHDOWN_LAG_S, TOUCHDOWN_RECOVERY_S = 6.0, 3.0
TOUCHDOWN_MIN_MPS = 0.1  # PX4's velocity square 1 crept onto the ground at under 0.1 m/s: its estimate went 0.2 m low
# EKF2's GPS quality checks must pass this long before it fuses a GPS (EKF2 _min_gps_health_time_us, 10 s)
GPS_CHECKS_PASS_S = 10.0


def estimator_flags(boot_s, ready_delay_s, armed):
    """ESTIMATOR_STATUS.flags `boot_s` after boot, for an estimator ready after `ready_delay_s`
    (a sooner ready brings each stage forward with it)."""
    if armed:
        return ESTIMATOR_FLAGS_FLYING
    if boot_s >= min(ESTIMATOR_HORIZONTAL_S, ready_delay_s):
        return ESTIMATOR_FLAGS_READY
    if boot_s >= min(ESTIMATOR_ATTITUDE_S, ready_delay_s):
        return ESTIMATOR_FLAGS_ATTITUDE
    return ESTIMATOR_FLAGS_BOOT


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
        self.bias_phase = self.rng.uniform(0.0, 2.0 * math.pi) if not ideal else 0.0
        self.flight_s = 0.0          # seconds airborne in this flight, the bias's time
        self.velocity_bias = (0.0, 0.0, 0.0)
        self.lag_velocity = 0.0      # the touchdown the vertical estimate has not followed yet (m/s, down)
        self.lag_height = 0.0        # ... and where it has taken the height (m, down)
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

    def touchdown(self, vz_mps):
        """The vehicle hit the ground descending at vz_mps (down positive): EKF2 follows the stop late. A touch
        slower than TOUCHDOWN_MIN_MPS (a hop on the ground, a creeping landing) leaves no lag."""
        if not self.ideal and vz_mps >= TOUCHDOWN_MIN_MPS:
            self.lag_velocity = max(self.lag_velocity, vz_mps)

    def step_errors(self, dt, airborne):
        """Advance the estimate's errors by dt: the bias while airborne, the touchdown lag and its recovery."""
        if self.ideal:
            return
        if airborne:
            self.flight_s += dt
            wave = (math.sin(2.0 * math.pi * self.flight_s / VELOCITY_BIAS_PERIOD_S + self.bias_phase)
                    * (1.0 - math.exp(-self.flight_s / VELOCITY_BIAS_ONSET_S)))
            self.velocity_bias = tuple(a * wave for a in VELOCITY_BIAS_MPS)
        else:
            self.flight_s, self.velocity_bias = 0.0, (0.0, 0.0, 0.0)
        if self.lag_velocity or self.lag_height:
            self.lag_velocity *= math.exp(-dt / TOUCHDOWN_LAG_S)
            self.lag_height += (self.lag_velocity - self.lag_height / TOUCHDOWN_RECOVERY_S) * dt
            if self.lag_velocity < 1e-4 and abs(self.lag_height) < 1e-4:
                self.lag_velocity = self.lag_height = 0.0

    def measure(self, position, velocity, resting=False):
        if self.ideal:
            return tuple(position), tuple(velocity)
        g = self.rng.gauss
        k = RESTING_NOISE_SCALE if resting else 1.0
        bias = self.velocity_bias
        lag_vz = self.lag_velocity - self.lag_height / TOUCHDOWN_RECOVERY_S
        pos = (position[0] + g(0.0, k * NOISE_POSITION_XY), position[1] + g(0.0, k * NOISE_POSITION_XY),
               position[2] + self.lag_height + g(0.0, k * NOISE_POSITION_Z))
        vel = (velocity[0] + bias[0] + g(0.0, k * NOISE_VELOCITY), velocity[1] + bias[1] + g(0.0, k * NOISE_VELOCITY),
               velocity[2] + bias[2] + lag_vz + g(0.0, k * NOISE_VELOCITY))
        return pos, vel
