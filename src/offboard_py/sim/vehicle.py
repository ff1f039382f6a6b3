"""Multicopter model of the simulated PX4: PX4's position control over SIH's airframe.

Controller, as PX4's mc_pos_control (PositionControl, TakeoffHandling):
- position error -> velocity setpoint (MPC_XY_P, MPC_Z_P, plus the setpoint's feed-forward),
  limited by MPC_XY_VEL_MAX / MPC_Z_VEL_MAX_UP / _DN or the tighter limits a flight mode asks for;
- velocity error -> acceleration setpoint by a PID (MPC_*_VEL_P_ACC, _I_ACC, _D_ACC) with PX4's
  anti-windup (vertical: no integration into a thrust limit; horizontal: tracking anti-windup);
- acceleration -> a thrust vector with MPC_THR_HOVER as the hover thrust, the tilt limited to
  MPC_TILTMAX_AIR, the collective thrust to [MPC_THR_MIN, MPC_THR_MAX], vertical first;
- takeoff: spool-up (COM_SPOOLUP_TIME), then the climb-rate limit ramps over MPC_TKO_RAMP_T from
  -g / MPC_Z_VEL_P_ACC (zero thrust) to the climb speed, as PX4's takeoff ramp does.
Airframe, as PX4's SIH quadrotor: mass SIH_MASS, four rotors of SIH_T_MAX each, linear drag
SIH_KDV (which is what holds the cruise speed below MPC_XY_VEL_MAX with a 45 deg tilt), the
collective thrust following the command with the motor constant SIH_T_TAU, and the thrust's
direction turned by PX4's attitude loop: the tilt error times MC_ROLL_P / MC_PITCH_P asks for a
body rate, limited to MC_ROLLRATE_MAX / MC_PITCHRATE_MAX, which the rate loop and rotors reach as a
second-order response, all PIPELINE_DELAY_S after the position controller asked (fitted to the
30 m step of reference/px4-sitl-measured.md, "Turn 3 recordings", section 2: pitch rate first above
0.4 rad/s at about 100 ms, its peak 2.8 rad/s at about 240 ms, pitch -40 deg at 0.5 s and -44 deg
at 1 s). The body rates are the model's; the gyro and accelerometer add SIH's noise (sim.sensors).
An optional gust (a seeded Ornstein-Uhlenbeck acceleration) makes the vehicle wander in hover
as PX4 SITL's does; the estimate the controller flies and telemetry reports carries a little
white noise (`Estimator`). Both are off for an ideal vehicle.
The ground is flat at z = `ground_z` (local NED): PX4's estimate on the ground reads a little
above its origin (NED z negative). A land detector in PX4's three stages (ground contact, maybe landed, landed) with
its thrust thresholds says `landed`.

All in local NED (m, m/s), yaw in rad from north. Time is passed in; nothing is read
from a clock. No MAVLink, no ROS.
"""

import math
import random
from collections import deque, namedtuple

from offboard_py.sim.sensors import Imu

GRAVITY = 9.80665
# PX4's attitude pipeline, fitted to the 30 m step (module docstring): from the position controller's
# thrust setpoint to the attitude controller (estimator and controller rates, uORB), and the rate
# loop with the rotors as a second-order response (natural frequency rad/s, damping ratio)
PIPELINE_DELAY_S = 0.06
RATE_WN, RATE_ZETA = 16.0, 0.55
ATTITUDE_SUBSTEP_S = 0.01  # the rate response is integrated in steps no longer than this
YAW_P = 2.8               # MC_YAW_P
YAW_RATE_MAX = math.radians(200.0)  # MC_YAWRATE_MAX
NAN = float('nan')
TILT_LIMIT_SLEW = 0.2     # rad/s: how fast PX4 lets the tilt limit change (_tilt_limit_slew_rate)
# PX4's MulticopterLandDetector: hysteresis of its stages and its thrust thresholds
GROUND_CONTACT_S, MAYBE_LANDED_S, LANDED_S = 0.35, 0.25, 0.3
# (MulticopterLandDetector.cpp: low thrust 30 % of the range, 60 % with a valid hover-thrust estimate,
# which PX4 SITL always has; minimal thrust 10 %). The 10 % is what makes a takeoff lose maybe-landed
# early in the ramp: landed_state IN_AIR 1.86 and 1.98 s after an OFFBOARD arm (reference/conversations),
# and a disarm 1.9 s after the arm TEMPORARILY_REJECTED (reference/px4-sitl-measured.md, "Turn 3
# recordings", section 6)
LOW_THRUST_FRACTION = 0.6      # of (hover - MPC_THR_MIN) above MPC_THR_MIN: "low thrust"
MINIMAL_THRUST_FRACTION = 0.1  # ... "minimal thrust" (maybe landed)
TAKEOFF_TRIGGER_M = 0.2        # a position setpoint this far above asks for a takeoff (PX4)
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

Setpoint = namedtuple('Setpoint', 'position velocity acceleration yaw yaw_rate xy_speed_max z_up_max z_down_max')
Setpoint.__doc__ = """What a flight mode asks of the controller. Vectors are NED 3-tuples whose NaN
components are not controlled; yaw/yaw_rate NaN means "keep". The *_max fields, when not
None, tighten the MPC_* velocity limits (takeoff and landing speeds, cruise speed)."""


def setpoint(position=(NAN, NAN, NAN), velocity=(NAN, NAN, NAN), acceleration=(NAN, NAN, NAN),
             yaw=NAN, yaw_rate=NAN, xy_speed_max=None, z_up_max=None, z_down_max=None):
    return Setpoint(tuple(position), tuple(velocity), tuple(acceleration), yaw, yaw_rate,
                    xy_speed_max, z_up_max, z_down_max)


def hold(position, yaw):
    """Hover at `position` facing `yaw`."""
    return setpoint(position=position, yaw=yaw)


def _clamp(value, low, high):
    return low if value < low else high if value > high else value


def _limit_xy(vx, vy, limit):
    norm = math.hypot(vx, vy)
    if norm > limit > 0.0:
        return vx * limit / norm, vy * limit / norm
    return (0.0, 0.0) if limit <= 0.0 else (vx, vy)


def _is(value):
    return value == value  # not NaN


def quaternion_from_thrust(acc_ned, yaw):
    """Attitude (w, x, y, z), NED/FRD, that points the thrust to give `acc_ned` with heading yaw."""
    fx, fy, fz = acc_ned[0], acc_ned[1], acc_ned[2] - GRAVITY
    norm = math.sqrt(fx * fx + fy * fy + fz * fz) or 1.0
    zb = (-fx / norm, -fy / norm, -fz / norm)          # body z (down) opposite the thrust
    yc = (-math.sin(yaw), math.cos(yaw), 0.0)
    xb = (yc[1] * zb[2] - yc[2] * zb[1], yc[2] * zb[0] - yc[0] * zb[2], yc[0] * zb[1] - yc[1] * zb[0])
    n = math.sqrt(xb[0] * xb[0] + xb[1] * xb[1] + xb[2] * xb[2]) or 1.0
    xb = (xb[0] / n, xb[1] / n, xb[2] / n)
    yb = (zb[1] * xb[2] - zb[2] * xb[1], zb[2] * xb[0] - zb[0] * xb[2], zb[0] * xb[1] - zb[1] * xb[0])
    # rotation matrix columns xb, yb, zb -> quaternion
    m00, m11, m22 = xb[0], yb[1], zb[2]
    trace = m00 + m11 + m22
    if trace > 0.0:
        s = math.sqrt(trace + 1.0) * 2.0
        return (0.25 * s, (yb[2] - zb[1]) / s, (zb[0] - xb[2]) / s, (xb[1] - yb[0]) / s)
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2.0
        return ((yb[2] - zb[1]) / s, 0.25 * s, (yb[0] + xb[1]) / s, (zb[0] + xb[2]) / s)
    if m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2.0
        return ((zb[0] - xb[2]) / s, (yb[0] + xb[1]) / s, 0.25 * s, (zb[1] + yb[2]) / s)
    s = math.sqrt(1.0 + m22 - m00 - m11) * 2.0
    return ((xb[1] - yb[0]) / s, (zb[0] + xb[2]) / s, (zb[1] + yb[2]) / s, 0.25 * s)


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


class Vehicle:
    """State and dynamics of one multicopter. `params` is a ParamStore (read every step).
    `position`/`velocity` are the truth; `estimate` is what PX4 knows (and reports)."""

    def __init__(self, params, position=None, yaw=0.0, estimator=None, ground_z=None):
        self.params = params
        self.estimator = estimator or Estimator(ideal=True)
        start = (0.0, 0.0, 0.0) if self.estimator.ideal else ground_start(self.estimator.seed)
        if ground_z is None:
            ground_z = start[2]
        self.ground_z = ground_z
        self.position = list(position) if position is not None else [start[0], start[1], ground_z]
        self.velocity = [0.0, 0.0, 0.0]
        self.acceleration = [0.0, 0.0, 0.0]   # achieved, net of gravity
        self.thrust = [0.0, 0.0, 0.0]         # normalised thrust vector (NED), as the rotors give it
        self.collective = 0.0                 # its magnitude
        self.tilt = [0.0, 0.0, 1.0]           # the body's z axis (down) in NED: the thrust points against it
        self.tilt_rates = [0.0, 0.0]          # roll and pitch rate (rad/s) ...
        self.tilt_rates_dot = [0.0, 0.0]      # ... and their derivatives: the rate loop's state
        self._pending = deque([(-1.0, (0.0, 0.0, 0.0))])  # thrust setpoints on their way (PIPELINE_DELAY_S)
        self.yaw = yaw
        self.yaw_rate = 0.0
        self.imu = Imu(self.estimator.seed, ideal=self.estimator.ideal)
        self._gust = (0.0, 0.0, 0.0)  # this step's
        self.body_rates = (0.0, 0.0, 0.0)  # FRD, rad/s: the filtered gyro (ATTITUDE), see sim.sensors
        self.gyro = (0.0, 0.0, 0.0)        # FRD, rad/s: the gyro (HIGHRES_IMU)
        self.motors_on = False
        self.motors_on_s = None
        self.takeoff_state = 'disarmed'  # PX4's TakeoffHandling: disarmed, spoolup, ready, rampup, flight
        self.ramp_vz = 0.0            # takeoff ramp: the climb-rate limit now (m/s, up positive)
        self.integral = [0.0, 0.0, 0.0]
        # PX4 limits the tilt to MPC_TILTMAX_LND until the takeoff is over, then lets the limit
        # grow to MPC_TILTMAX_AIR at TILT_LIMIT_SLEW rad/s (MulticopterPositionControl)
        self.tilt_limit = math.radians(params['MPC_TILTMAX_LND'])
        self.ground_contact = self.position[2] >= ground_z
        self.contact_since_s = 0.0 if self.ground_contact else None
        self.landed = self.ground_contact
        self._stages = {}  # land-detector stage -> [state, since when its condition holds]
        self._now_s = None  # the time of the last step
        self._reset_stages(self.landed)
        self.estimate = (tuple(self.position), (0.0, 0.0, 0.0))
        self._attitude = None  # cached for the current step: telemetry asks more often than we step
        # what the controller tracks, for telemetry (POSITION_TARGET_LOCAL_NED, ATTITUDE_TARGET):
        # the setpoint flown, the velocity setpoint it gave (NaN where not controlled) and the
        # commanded acceleration; None while the motors do not fly
        self.setpoint = None
        self.velocity_setpoint = (NAN, NAN, NAN)
        self.acceleration_setpoint = None
        self.thrust_setpoint = [0.0, 0.0, 0.0]

    # -- commands from the commander -----------------------------------------------------

    def start_motors(self, now_s):
        self.motors_on, self.motors_on_s = True, now_s
        self.takeoff_state = 'spoolup' if self.landed else 'flight'
        self.integral = [0.0, 0.0, 0.0]

    def stop_motors(self):
        self.motors_on, self.motors_on_s, self.takeoff_state = False, None, 'disarmed'
        self.integral = [0.0, 0.0, 0.0]

    def spooled_up(self, now_s):
        return self.motors_on and now_s - self.motors_on_s >= self.params['COM_SPOOLUP_TIME']

    # -- PX4's takeoff handling --------------------------------------------------------------

    def _update_takeoff(self, sp, now_s, dt, climb_speed):
        p, state = self.params, self.takeoff_state
        if state == 'spoolup' and self.spooled_up(now_s):
            state = 'ready'
        if state == 'ready':
            z = self.estimate[0][2]
            wants = ((_is(sp.position[2]) and sp.position[2] < z - TAKEOFF_TRIGGER_M)
                     or (_is(sp.velocity[2]) and not _is(sp.position[2]) and sp.velocity[2] < -TAKEOFF_TRIGGER_M))
            if wants:
                state = 'rampup'
                self.ramp_vz = -GRAVITY / p['MPC_Z_VEL_P_ACC']  # from zero thrust
        if state == 'rampup':
            ramp_s = p['MPC_TKO_RAMP_T']
            if ramp_s > dt:
                self.ramp_vz += (climb_speed + GRAVITY / p['MPC_Z_VEL_P_ACC']) * dt / ramp_s
            else:
                self.ramp_vz = climb_speed
            if self.ramp_vz >= climb_speed:
                state = 'flight'
        if state == 'flight' and self.landed:
            state = 'ready'
        self.takeoff_state = state

    # -- the controller ----------------------------------------------------------------------

    def _velocity_setpoint(self, sp, pos):
        p = self.params
        position, velocity = sp.position, sp.velocity
        xy_gain = p['MPC_XY_P']
        vel_sp = [0.0, 0.0, 0.0]
        controlled = [False, False, False]
        for i in (0, 1, 2):
            v = velocity[i]
            target = position[i]
            if target == target:  # not NaN: position control, with the setpoint's velocity as feed-forward
                vel_sp[i] = (v if v == v else 0.0) + (xy_gain if i < 2 else p['MPC_Z_P']) * (target - pos[i])
                controlled[i] = True
            elif v == v:
                vel_sp[i] = v
                controlled[i] = True
        xy_max = p['MPC_XY_VEL_MAX'] if sp.xy_speed_max is None else min(sp.xy_speed_max, p['MPC_XY_VEL_MAX'])
        up_max = p['MPC_Z_VEL_MAX_UP'] if sp.z_up_max is None else min(sp.z_up_max, p['MPC_Z_VEL_MAX_UP'])
        dn_max = p['MPC_Z_VEL_MAX_DN'] if sp.z_down_max is None else min(sp.z_down_max, p['MPC_Z_VEL_MAX_DN'])
        if self.takeoff_state == 'rampup':
            up_max = min(up_max, self.ramp_vz)  # negative early in the ramp: push down, no thrust
        vel_sp[0], vel_sp[1] = _limit_xy(vel_sp[0], vel_sp[1], xy_max)
        low = -up_max
        vel_sp[2] = _clamp(vel_sp[2], low, max(dn_max, low))
        self.velocity_setpoint = (vel_sp[0] if controlled[0] else NAN, vel_sp[1] if controlled[1] else NAN,
                                  vel_sp[2] if controlled[2] else NAN)
        return vel_sp, controlled

    def _control(self, sp, dt):
        """PX4's PositionControl: the normalised thrust vector (NED) for setpoint `sp`."""
        p = self.params
        pos, vel = self.estimate
        vel_sp, controlled = self._velocity_setpoint(sp, pos)
        xy_p, z_p = p['MPC_XY_VEL_P_ACC'], p['MPC_Z_VEL_P_ACC']
        gains_i = (p['MPC_XY_VEL_I_ACC'], p['MPC_XY_VEL_I_ACC'], p['MPC_Z_VEL_I_ACC'])
        gains_d = (p['MPC_XY_VEL_D_ACC'], p['MPC_XY_VEL_D_ACC'], p['MPC_Z_VEL_D_ACC'])
        error = [vel_sp[0] - vel[0] if controlled[0] else 0.0, vel_sp[1] - vel[1] if controlled[1] else 0.0,
                 vel_sp[2] - vel[2] if controlled[2] else 0.0]
        acc = [0.0, 0.0, 0.0]
        sp_acc, integral, achieved = sp.acceleration, self.integral, self.acceleration
        for i in (0, 1, 2):
            ff = sp_acc[i]
            if ff != ff:
                ff = 0.0
            if controlled[i]:
                acc[i] = ff + (xy_p if i < 2 else z_p) * error[i] + integral[i] - gains_d[i] * achieved[i]
            else:
                acc[i] = ff
        # acceleration -> thrust (MPC_ACC_DECOUPLE: the vertical thrust holds the vertical acceleration)
        hover, thr_min, thr_max = p['MPC_THR_HOVER'], p['MPC_THR_MIN'], p['MPC_THR_MAX']
        if self.takeoff_state == 'rampup':
            thr_min = 0.0  # PX4 ramps from zero thrust on takeoff
        bx, by, bz = -acc[0], -acc[1], GRAVITY
        norm = math.sqrt(bx * bx + by * by + bz * bz)
        bx, by, bz = bx / norm, by / norm, bz / norm
        wanted = p['MPC_TILTMAX_AIR'] if self.takeoff_state == 'flight' else p['MPC_TILTMAX_LND']
        step = TILT_LIMIT_SLEW * dt
        self.tilt_limit += _clamp(math.radians(wanted) - self.tilt_limit, -step, step)
        tilt_max = self.tilt_limit
        if math.acos(_clamp(bz, -1.0, 1.0)) > tilt_max:
            horizontal = math.hypot(bx, by)
            bx, by, bz = bx / horizontal * math.sin(tilt_max), by / horizontal * math.sin(tilt_max), math.cos(tilt_max)
        collective = (acc[2] * hover / GRAVITY - hover) / bz
        collective = min(collective, -thr_min)
        thrust = [bx * collective, by * collective, bz * collective]
        # saturation: vertical first, what is left for the horizontal
        if thrust[2] < -thr_max:
            thrust[2] = -thr_max
        xy_room = math.sqrt(max(thr_max * thr_max - thrust[2] * thrust[2], 0.0))
        thrust[0], thrust[1] = _limit_xy(thrust[0], thrust[1], xy_room)
        # anti-windup: no vertical integration into a thrust limit; horizontal tracking anti-windup
        if (thrust[2] >= -thr_min and error[2] >= 0.0) or (thrust[2] <= -thr_max and error[2] <= 0.0):
            error[2] = 0.0
        produced = (thrust[0] * GRAVITY / hover, thrust[1] * GRAVITY / hover)
        if acc[0] ** 2 + acc[1] ** 2 > produced[0] ** 2 + produced[1] ** 2:
            arw = 2.0 / xy_p
            error[0] -= arw * (acc[0] - produced[0])
            error[1] -= arw * (acc[1] - produced[1])
        for i in (0, 1, 2):
            if controlled[i]:
                integral[i] += gains_i[i] * error[i] * dt
        integral[2] = _clamp(integral[2], -GRAVITY, GRAVITY)
        self.acceleration_setpoint = acc
        return thrust

    # -- dynamics --------------------------------------------------------------------------

    def step(self, dt, sp, now_s):
        """Advance the model by dt seconds, flying setpoint `sp` when the motors allow."""
        p = self.params
        self._now_s = now_s
        climb_speed = p['MPC_Z_VEL_MAX_UP'] if sp.z_up_max is None else min(sp.z_up_max, p['MPC_Z_VEL_MAX_UP'])
        if self.motors_on:
            self._update_takeoff(sp, now_s, dt, climb_speed)
        flying = self.takeoff_state in ('rampup', 'flight')
        if flying:
            thrust_sp = self._control(sp, dt)
            if _is(sp.yaw):
                yaw_rate = YAW_P * math.atan2(math.sin(sp.yaw - self.yaw), math.cos(sp.yaw - self.yaw))
            else:
                yaw_rate = sp.yaw_rate if _is(sp.yaw_rate) else 0.0
            self.yaw_rate = _clamp(yaw_rate, -YAW_RATE_MAX, YAW_RATE_MAX)
            self.setpoint = sp
        else:
            # motors off or idling, the controller held (PX4 resets its integrals until the ramp)
            thrust_sp = [0.0, 0.0, 0.0]
            self.integral = [0.0, 0.0, 0.0]
            self.yaw_rate = 0.0
            self.setpoint, self.acceleration_setpoint = None, None
            self.velocity_setpoint = (NAN, NAN, NAN)
        self.thrust_setpoint = thrust_sp
        self._attitude_loop(self._delayed(thrust_sp, now_s), dt)
        mass = max(p['SIH_MASS'], 0.01)  # SIH's airframe parameters are not range-checked
        thrust_acc = 4.0 * p['SIH_T_MAX'] / mass   # m/s^2 at full thrust
        drag = p['SIH_KDV'] / mass
        gust = self.estimator.step_gust(dt) if flying and not self.ground_contact else (0.0, 0.0, 0.0)
        self._gust = gust
        thrust, acceleration, velocity, position = self.thrust, self.acceleration, self.velocity, self.position
        tilt, collective = self.tilt, self.collective
        for i in (0, 1, 2):
            thrust[i] = -tilt[i] * collective
            acceleration[i] = (thrust[i] * thrust_acc + (GRAVITY if i == 2 else 0.0)
                               - drag * velocity[i] + gust[i])
            velocity[i] += acceleration[i] * dt
            position[i] += velocity[i] * dt
        self.yaw = math.atan2(math.sin(self.yaw + self.yaw_rate * dt), math.cos(self.yaw + self.yaw_rate * dt))
        # at rest with the motors off: the quiet estimate and IMU recorded on the ground (sections 2
        # and 7 were disarmed); with the motors on the controller flies the full noise, as in the air
        resting = self._ground(now_s) and not self.motors_on
        self.estimate = self.estimator.measure(self.position, self.velocity, resting)
        self._land_detector(sp, now_s)
        self._attitude = None
        imu = self.imu
        imu.step(dt, (self.tilt_rates[0], self.tilt_rates[1], self.yaw_rate), self._specific_force(), resting)
        self.body_rates, self.gyro = imu.rates, imu.gyro

    def _delayed(self, thrust_sp, now_s):
        """The thrust setpoint the attitude controller works on now: the one of PIPELINE_DELAY_S ago."""
        pending = self._pending
        pending.append((now_s, thrust_sp))
        due = now_s - PIPELINE_DELAY_S + 1e-9
        while len(pending) > 1 and pending[1][0] <= due:
            pending.popleft()
        return pending[0][1]

    def _attitude_loop(self, thrust_sp, dt):
        """PX4's attitude and rate control with the rotors: turn the body's z axis towards the
        thrust setpoint's direction, and the collective towards its magnitude (SIH_T_TAU)."""
        p = self.params
        tx, ty, tz = thrust_sp
        magnitude = math.sqrt(tx * tx + ty * ty + tz * tz)
        self.collective += min(1.0, dt / max(p['SIH_T_TAU'], dt)) * (magnitude - self.collective)
        b, rates, rates_dot = self.tilt, self.tilt_rates, self.tilt_rates_dot
        if magnitude > 1e-6:
            want = (-tx / magnitude, -ty / magnitude, -tz / magnitude)
        elif b[2] == 1.0 and not (rates[0] or rates[1] or rates_dot[0] or rates_dot[1]):
            return  # level, still and asked for nothing (idle on the ground): nothing turns
        else:
            want = (0.0, 0.0, 1.0)
        # the tilt error as a rotation vector (world frame), then in the heading frame: roll about
        # the heading (forward), pitch about its right
        cx, cy = b[1] * want[2] - b[2] * want[1], b[2] * want[0] - b[0] * want[2]
        sin_err = math.sqrt(cx * cx + cy * cy + (b[0] * want[1] - b[1] * want[0]) ** 2)
        if sin_err > 1e-9:
            scale = math.atan2(sin_err, b[0] * want[0] + b[1] * want[1] + b[2] * want[2]) / sin_err
        else:
            scale = 1.0
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        roll_max, pitch_max = math.radians(p['MC_ROLLRATE_MAX']), math.radians(p['MC_PITCHRATE_MAX'])
        rates_sp = (_clamp(p['MC_ROLL_P'] * scale * (cx * c + cy * s), -roll_max, roll_max),
                    _clamp(p['MC_PITCH_P'] * scale * (cy * c - cx * s), -pitch_max, pitch_max))
        roll_sp, pitch_sp = rates_sp
        substeps = int(dt / ATTITUDE_SUBSTEP_S - 1e-9) + 1
        h = dt / substeps
        wn2h, damping_h = RATE_WN * RATE_WN * h, 2.0 * RATE_ZETA * RATE_WN * h
        roll, pitch = rates
        roll_dot, pitch_dot = rates_dot
        bx, by, bz = b
        for _ in range(substeps):
            roll_dot += wn2h * (roll_sp - roll) - damping_h * roll_dot
            pitch_dot += wn2h * (pitch_sp - pitch) - damping_h * pitch_dot
            roll += roll_dot * h
            pitch += pitch_dot * h
            # the body turns at the rates (heading frame -> world), b' = w x b
            wx, wy = (roll * c - pitch * s) * h, (roll * s + pitch * c) * h
            bx, by, bz = bx + wy * bz, by - wx * bz, bz + wx * by - wy * bx
            n = math.sqrt(bx * bx + by * by + bz * bz)
            bx, by, bz = bx / n, by / n, bz / n
        rates[0], rates[1], rates_dot[0], rates_dot[1] = roll, pitch, roll_dot, pitch_dot
        b[0], b[1], b[2] = bx, by, bz

    def _ground(self, now_s):
        """The flat ground at ground_z; True while the vehicle rests on it."""
        gz = self.ground_z
        if self.position[2] >= gz and (self.velocity[2] >= 0.0 or self.acceleration[2] >= 0.0):
            # touching down or resting: the ground takes the load and stops the vehicle, levels it
            # and stops its turning (SIH's ground zeroes the body rates)
            self.position[2] = gz
            self.velocity = [0.0, 0.0, 0.0]
            self.acceleration = [min(a, 0.0) if i == 2 else 0.0 for i, a in enumerate(self.acceleration)]
            self.tilt[0], self.tilt[1], self.tilt[2] = 0.0, 0.0, 1.0
            self.tilt_rates[0] = self.tilt_rates[1] = self.tilt_rates_dot[0] = self.tilt_rates_dot[1] = 0.0
            if not self.ground_contact:
                self.ground_contact, self.contact_since_s = True, now_s
            return True
        if self.position[2] < gz - 0.02:
            self.ground_contact, self.contact_since_s = False, None
        return False

    def _reset_stages(self, state):
        self._stages = {name: [state, None] for name in ('contact', 'maybe', 'landed')}

    def _stage(self, name, condition, hold_s, now_s):
        """A land-detector stage with PX4's hysteresis: it becomes true once `condition` held for
        hold_s, and false at once when the condition fails."""
        stage = self._stages[name]
        if not condition:
            stage[0], stage[1] = False, None
        elif not stage[0]:
            if stage[1] is None:
                stage[1] = now_s
            stage[0] = now_s - stage[1] >= hold_s
        return stage[0]

    def _land_detector(self, sp, now_s):
        """PX4's MulticopterLandDetector: ground contact, maybe landed, landed."""
        if not self.motors_on or self.takeoff_state in ('spoolup', 'ready'):
            # disarmed or idling on the ground: landed while resting on it
            self.landed = self.ground_contact and (self.landed or now_s - self.contact_since_s >= LANDED_S)
            self._reset_stages(self.landed)
            return
        p = self.params
        vel = self.estimate[1]
        hover, thr_min = p['MPC_THR_HOVER'], p['MPC_THR_MIN']
        tx, ty, tz = self.thrust_setpoint
        thrust = math.sqrt(tx * tx + ty * ty + tz * tz)
        low_thrust = thrust <= thr_min + (hover - thr_min) * LOW_THRUST_FRACTION
        minimal_thrust = thrust <= thr_min + (hover - thr_min) * MINIMAL_THRUST_FRACTION
        vz_sp = self.velocity_setpoint[2]
        descending = vz_sp == vz_sp and vz_sp >= 1.1 * p['LNDMC_Z_VEL_MAX']
        still = abs(vel[2]) < p['LNDMC_Z_VEL_MAX'] and math.hypot(vel[0], vel[1]) < p['LNDMC_XY_VEL_MAX']
        contact = self._stage('contact', (low_thrust or (descending and still)) and still, GROUND_CONTACT_S, now_s)
        maybe = self._stage('maybe', contact and minimal_thrust, MAYBE_LANDED_S, now_s)
        self.landed = self._stage('landed', maybe, LANDED_S, now_s)

    def ground_contact_held_s(self):
        """How long the land detector has said ground contact on the ground (s), or None while it does
        not (a brief false contact in the air, as a descent starts, does not count)."""
        state, since = self._stages['contact']
        if not (state and self.ground_contact) or since is None or self._now_s is None:
            return None
        return max(0.0, self._now_s - since - GROUND_CONTACT_S)

    @property
    def maybe_landed(self):
        """The land detector's maybe-landed stage (or landed): what lets PX4's commander disarm."""
        return self.landed or self._stages['maybe'][0]

    # -- derived quantities ---------------------------------------------------------------

    def attitude(self):
        """(w, x, y, z) NED/FRD quaternion: the body's tilt, with the yaw."""
        if self._attitude is None:
            b = self.tilt
            self._attitude = quaternion_from_thrust((-b[0], -b[1], GRAVITY - b[2]), self.yaw)
        return self._attitude

    def collective_thrust(self):
        """Normalised thrust 0..1 the rotors give now."""
        return min(1.0, self.collective)

    def specific_force_body(self):
        """What the accelerometer reads (m/s^2, FRD), with its noise (sim.sensors)."""
        return self.imu.accel

    def _specific_force(self):
        """The true specific force (m/s^2, FRD): acceleration minus gravity, in body axes, without
        the gust (it stands for the estimate's drift: SIH has no wind, its accelerometer reads thrust
        and drag)."""
        w, x, y, z = self.attitude()
        a, gust = self.acceleration, self._gust
        f = (a[0] - gust[0], a[1] - gust[1], a[2] - gust[2] - GRAVITY)
        # rotate world->body: R^T f
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        return (r00 * f[0] + r10 * f[1] + r20 * f[2],
                r01 * f[0] + r11 * f[1] + r21 * f[2],
                r02 * f[0] + r12 * f[1] + r22 * f[2])

    def height(self):
        """Height above the ground (m, up positive): what the landing speeds go by."""
        return self.ground_z - self.position[2]
