"""Multicopter model of the simulated PX4: PX4's position control over SIH's airframe.

Controller (sim.position_control), as PX4's mc_pos_control (PositionControl, TakeoffHandling):
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
white noise (sim.estimator). Both are off for an ideal vehicle.
The ground is flat at z = `ground_z` (local NED): PX4's estimate on the ground reads a little
above its origin (NED z negative). PX4's land detector (sim.land_detector) says `landed`.

All in local NED (m, m/s), yaw in rad from north. Time is passed in; nothing is read
from a clock. No MAVLink, no ROS.
"""

import math
from collections import deque, namedtuple

from offboard_py.sim.estimator import Estimator, ground_start
from offboard_py.sim.flight_math import GRAVITY, NAN, clamp, is_set, quaternion_from_thrust, wrap_pi
from offboard_py.sim.land_detector import LandDetector
from offboard_py.sim.position_control import PositionControl
from offboard_py.sim.sensors import SihImu

# PX4's attitude pipeline, fitted to the 30 m step (module docstring): from the position controller's
# thrust setpoint to the attitude controller (estimator and controller rates, uORB), and the rate
# loop with the rotors as a second-order response (natural frequency rad/s, damping ratio)
PIPELINE_DELAY_S = 0.06
RATE_WN, RATE_ZETA = 16.0, 0.55
ATTITUDE_SUBSTEP_S = 0.01  # the rate response is integrated in steps no longer than this
YAW_P = 2.8               # MC_YAW_P
YAW_RATE_MAX = math.radians(200.0)  # MC_YAWRATE_MAX
Setpoint = namedtuple('Setpoint', 'position velocity acceleration yaw yaw_rate xy_speed_max z_up_max z_down_max '
                                  'attitude thrust rates')
Setpoint.__doc__ = """What a flight mode asks of the controller. Vectors are NED 3-tuples whose NaN
components are not controlled; yaw/yaw_rate NaN means "keep". The *_max fields, when not
None, tighten the MPC_* velocity limits (takeoff and landing speeds, cruise speed). `attitude`
(w, x, y, z, NED/FRD, unit) or else `rates` (roll, pitch, yaw; FRD, rad/s), when not None, is flown
with collective `thrust` (0..1) without the position controller, as PX4's offboard attitude and
rate control do."""


def setpoint(position=(NAN, NAN, NAN), velocity=(NAN, NAN, NAN), acceleration=(NAN, NAN, NAN),
             yaw=NAN, yaw_rate=NAN, xy_speed_max=None, z_up_max=None, z_down_max=None, attitude=None, thrust=0.0,
             rates=None):
    return Setpoint(tuple(position), tuple(velocity), tuple(acceleration), yaw, yaw_rate,
                    xy_speed_max, z_up_max, z_down_max, attitude, thrust, rates)


def hold(position, yaw):
    """Hover at `position` facing `yaw`."""
    return setpoint(position=position, yaw=yaw)


class VehicleModel:
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
        self.imu = SihImu(self.estimator.seed, ideal=self.estimator.ideal)
        self._gust = (0.0, 0.0, 0.0)  # this step's
        self.body_rates = (0.0, 0.0, 0.0)  # FRD, rad/s: the filtered gyro (ATTITUDE), see sim.sensors
        self.gyro = (0.0, 0.0, 0.0)        # FRD, rad/s: the gyro (HIGHRES_IMU)
        self.motors_on = False
        self.motors_on_s = None
        self.control = PositionControl(params)  # PX4's mc_pos_control: what thrust the setpoint asks for
        self.ground_contact = self.position[2] >= ground_z
        self.contact_since_s = 0.0 if self.ground_contact else None
        self.landed = self.ground_contact
        self.land_detector = LandDetector(self.landed)
        self._now_s = None  # the time of the last step
        self.estimate = (tuple(self.position), (0.0, 0.0, 0.0))
        self._attitude = None  # cached for the current step: telemetry asks more often than we step
        # the setpoint flown (for telemetry; None while the motors do not fly) and the thrust asked for
        self.setpoint = None
        self.thrust_setpoint = [0.0, 0.0, 0.0]
        self._rates_sp = None  # offboard body rates (roll, pitch, yaw) this step, or None

    # -- commands from the commander -----------------------------------------------------

    def start_motors(self, now_s):
        self.motors_on, self.motors_on_s = True, now_s
        self.control.arm(self.landed)

    def stop_motors(self):
        self.motors_on, self.motors_on_s = False, None
        self.control.disarm()

    @property
    def takeoff_state(self):
        return self.control.takeoff_state

    @property
    def velocity_setpoint(self):
        return self.control.velocity_setpoint

    @property
    def acceleration_setpoint(self):
        return self.control.acceleration_setpoint

    def spooled_up(self, now_s):
        return self.motors_on and now_s - self.motors_on_s >= self.params['COM_SPOOLUP_TIME']

    # -- dynamics --------------------------------------------------------------------------

    def step(self, dt, sp, now_s):
        """Advance the model by dt seconds, flying setpoint `sp` when the motors allow."""
        p = self.params
        self._now_s = now_s
        climb_speed = p['MPC_Z_VEL_MAX_UP'] if sp.z_up_max is None else min(sp.z_up_max, p['MPC_Z_VEL_MAX_UP'])
        control = self.control
        self._rates_sp = None
        if (sp.attitude is not None or sp.rates is not None) and self.motors_on:
            thrust_sp = self._fly_attitude(sp, now_s)
            flying = control.flying()
        else:
            if self.motors_on:
                control.update_takeoff(sp, dt, climb_speed, self.spooled_up(now_s), self.estimate[0][2], self.landed)
            flying = control.flying()
            if flying:
                thrust_sp = control.thrust(sp, self.estimate, self.acceleration, dt)
                if self.land_detector.ground_contact and control.takeoff_state == 'flight':
                    # PX4's flying_but_ground_contact: no corrections, the least thrust, no integrator windup
                    thrust_sp = [0.0, 0.0, -p['MPC_THR_MIN']]
                    control.integral = [0.0, 0.0, 0.0]
                if is_set(sp.yaw):
                    yaw_rate = YAW_P * wrap_pi(sp.yaw - self.yaw)
                else:
                    yaw_rate = sp.yaw_rate if is_set(sp.yaw_rate) else 0.0
                self.yaw_rate = clamp(yaw_rate, -YAW_RATE_MAX, YAW_RATE_MAX)
                self.setpoint = sp
            else:
                # motors off or idling, the controller held (PX4 resets its integrals until the ramp)
                thrust_sp = [0.0, 0.0, 0.0]
                control.hold()
                self.yaw_rate = 0.0
                self.setpoint = None
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
        self.yaw = wrap_pi(self.yaw + self.yaw_rate * dt)
        # at rest with the motors off: the quiet estimate and IMU recorded on the ground (sections 2
        # and 7 were disarmed); with the motors on the controller flies the full noise, as in the air
        on_ground = self._ground(now_s)
        resting = on_ground and not self.motors_on
        self.estimator.step_errors(dt, not on_ground and self.motors_on)
        self.estimate = self.estimator.measure(self.position, self.velocity, resting)
        self._land_detector(sp, now_s)
        self._attitude = None
        imu = self.imu
        imu.step(dt, (self.tilt_rates[0], self.tilt_rates[1], self.yaw_rate), self._specific_force(), resting)
        self.body_rates, self.gyro = imu.rates, imu.gyro

    def _fly_attitude(self, sp, now_s):
        """PX4's offboard attitude control (SET_ATTITUDE_TARGET): the position controller does not
        run (its integrals reset, no takeoff ramp); once the motors have spooled up the thrust is
        the collective along the attitude's body z axis, and the heading turns to the attitude's
        yaw as in the other modes. Returns the thrust setpoint (normalised, NED)."""
        control = self.control
        control.hold()
        if not self.spooled_up(now_s):
            control.takeoff_state = 'spoolup'
            self.yaw_rate = 0.0
            self.setpoint = None
            return [0.0, 0.0, 0.0]
        control.takeoff_state = 'flight'  # what PX4's takeoff handling finds if position control resumes
        if sp.attitude is None:  # body rates: the rate loop turns the body, the thrust goes along it
            self._rates_sp = sp.rates
            body_z = self.tilt
        else:
            w, x, y, z = sp.attitude
            body_z = (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))
        thrust_sp = [-c * sp.thrust for c in body_z]
        p = self.params
        thrust_acc = 4.0 * p['SIH_T_MAX'] / max(p['SIH_MASS'], 0.01)
        control.acceleration_setpoint = [t * thrust_acc + (GRAVITY if i == 2 else 0.0) for i, t in enumerate(thrust_sp)]
        if sp.attitude is None:
            yaw_rate = sp.rates[2]
        else:
            yaw_rate = YAW_P * wrap_pi(sp.yaw - self.yaw)
        self.yaw_rate = clamp(yaw_rate, -YAW_RATE_MAX, YAW_RATE_MAX)
        self.setpoint = sp
        return thrust_sp

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
        if self._rates_sp is not None:  # offboard body rates: the rate loop's setpoint as given (FRD)
            asked = self._rates_sp[0], self._rates_sp[1]
        else:
            asked = p['MC_ROLL_P'] * scale * (cx * c + cy * s), p['MC_PITCH_P'] * scale * (cy * c - cx * s)
        rates_sp = (clamp(asked[0], -roll_max, roll_max), clamp(asked[1], -pitch_max, pitch_max))
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
            touchdown_vz = self.velocity[2]
            # touching down or resting: the ground takes the load and stops the vehicle, levels it
            # and stops its turning (SIH's ground zeroes the body rates)
            self.position[2] = gz
            self.velocity = [0.0, 0.0, 0.0]
            self.acceleration = [min(a, 0.0) if i == 2 else 0.0 for i, a in enumerate(self.acceleration)]
            self.tilt[0], self.tilt[1], self.tilt[2] = 0.0, 0.0, 1.0
            self.tilt_rates[0] = self.tilt_rates[1] = self.tilt_rates_dot[0] = self.tilt_rates_dot[1] = 0.0
            if not self.ground_contact:
                self.ground_contact, self.contact_since_s = True, now_s
                if self.motors_on:
                    self.estimator.touchdown(touchdown_vz)
            return True
        if self.position[2] < gz - 0.02:
            self.ground_contact, self.contact_since_s = False, None
        return False

    def _land_detector(self, sp, now_s):
        """PX4's MulticopterLandDetector (sim.land_detector) on this step's state."""
        idle = not self.motors_on or self.takeoff_state in ('spoolup', 'ready')
        self.landed = self.land_detector.update(self, idle, now_s)

    def ground_contact_held_s(self):
        """How long the land detector has said ground contact on the ground (s), or None while it does
        not (a brief false contact in the air, as a descent starts, does not count)."""
        if self._now_s is None:
            return None
        return self.land_detector.contact_held_s(self._now_s, self.ground_contact)

    @property
    def maybe_landed(self):
        """The land detector's maybe-landed stage (or landed): what lets PX4's commander disarm."""
        return self.landed or self.land_detector.maybe_landed

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
