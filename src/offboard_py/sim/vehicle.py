"""Multicopter model of the simulated PX4: a PX4-like control cascade over point-mass dynamics.

The controller is PX4's multicopter position control in miniature: a position error gives a
velocity setpoint (MPC_XY_P, MPC_Z_P) limited by MPC_XY_VEL_MAX / MPC_Z_VEL_MAX_UP / _DN
(or tighter limits a flight mode asks for), a velocity error gives an acceleration setpoint
(MPC_*_VEL_P_ACC) limited by MPC_ACC_UP_MAX / MPC_ACC_DOWN_MAX and the tilt limit. The airframe reaches the
commanded acceleration through a first-order lag (motors and attitude loop), and its
attitude is the one that points the thrust along that acceleration, with the yaw asked for.
A takeoff from the ground ramps the climb-rate limit from 0 to MPC_TKO_SPEED over
MPC_TKO_RAMP_T after the motors spool up, as PX4's takeoff handling does.
The ground is z = 0 (NED, home altitude): the vehicle cannot go below it and rests there
when it does not push upwards. A land detector reports ground contact and `landed` with
PX4-like hysteresis.

All in local NED (m, m/s), yaw in rad from north. Time is passed in; nothing is read
from a clock. No MAVLink, no ROS.
"""

import math
from collections import namedtuple

GRAVITY = 9.80665
ACC_LAG_S = 0.08          # motor + attitude loop response
YAW_P = 2.8               # MC_YAW_P
YAW_RATE_MAX = math.radians(200.0)  # MC_YAWRATE_MAX
LANDED_AFTER_S = 0.35     # ground contact this long -> landed
AIRBORNE_HEIGHT_M = 0.15  # higher than this above ground -> no longer landed
NAN = float('nan')

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
    n = math.sqrt(sum(c * c for c in xb)) or 1.0
    xb = tuple(c / n for c in xb)
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


class Vehicle:
    """State and dynamics of one multicopter. `params` is a ParamStore (read every step)."""

    def __init__(self, params, position=(0.0, 0.0, 0.0), yaw=0.0):
        self.params = params
        self.position = list(position)
        self.velocity = [0.0, 0.0, 0.0]
        self.acceleration = [0.0, 0.0, 0.0]   # achieved, net of gravity
        self.yaw = yaw
        self.yaw_rate = 0.0
        self.motors_on = False
        self.motors_on_s = None
        self.ramp_start_s = None  # takeoff ramp running since (None: not taking off)
        self.ground_contact = position[2] >= 0.0
        self.contact_since_s = 0.0 if self.ground_contact else None
        self.landed = self.ground_contact
        self._attitude = None  # cached for the current step: telemetry asks more often than we step
        # what the controller tracks, for telemetry (POSITION_TARGET_LOCAL_NED, ATTITUDE_TARGET):
        # the setpoint flown, the velocity setpoint it gave (NaN where not controlled) and the
        # commanded acceleration; None while the motors do not fly
        self.setpoint = None
        self.velocity_setpoint = (NAN, NAN, NAN)
        self.acceleration_setpoint = None

    # -- commands from the commander -----------------------------------------------------

    def start_motors(self, now_s):
        self.motors_on, self.motors_on_s = True, now_s
        self.ramp_start_s = now_s + self.params['COM_SPOOLUP_TIME'] if self.landed else None

    def stop_motors(self):
        self.motors_on, self.motors_on_s, self.ramp_start_s = False, None, None

    def _takeoff_climb_limit(self, now_s):
        """Climb-rate limit of the takeoff ramp, or None once the ramp is over."""
        if self.ramp_start_s is None:
            return None
        ramp_s = self.params['MPC_TKO_RAMP_T']
        elapsed = now_s - self.ramp_start_s
        if ramp_s <= 0.0 or elapsed >= ramp_s:
            self.ramp_start_s = None
            return None
        return self.params['MPC_TKO_SPEED'] * max(elapsed, 0.0) / ramp_s

    def spooled_up(self, now_s):
        return self.motors_on and now_s - self.motors_on_s >= self.params['COM_SPOOLUP_TIME']

    # -- dynamics --------------------------------------------------------------------------

    def _velocity_setpoint(self, sp, now_s):
        p = self.params
        vel_sp = [0.0, 0.0, 0.0]
        controlled = [False, False, False]
        gains = (p['MPC_XY_P'], p['MPC_XY_P'], p['MPC_Z_P'])
        for i in range(3):
            ff = sp.velocity[i] if _is(sp.velocity[i]) else 0.0
            if _is(sp.position[i]):
                vel_sp[i] = ff + gains[i] * (sp.position[i] - self.position[i])
                controlled[i] = True
            elif _is(sp.velocity[i]):
                vel_sp[i] = sp.velocity[i]
                controlled[i] = True
        xy_max = p['MPC_XY_VEL_MAX'] if sp.xy_speed_max is None else min(sp.xy_speed_max, p['MPC_XY_VEL_MAX'])
        up_max = p['MPC_Z_VEL_MAX_UP'] if sp.z_up_max is None else min(sp.z_up_max, p['MPC_Z_VEL_MAX_UP'])
        ramp = self._takeoff_climb_limit(now_s)
        if ramp is not None:
            up_max = min(up_max, ramp)
        dn_max = p['MPC_Z_VEL_MAX_DN'] if sp.z_down_max is None else min(sp.z_down_max, p['MPC_Z_VEL_MAX_DN'])
        vel_sp[0], vel_sp[1] = _limit_xy(vel_sp[0], vel_sp[1], xy_max)
        vel_sp[2] = _clamp(vel_sp[2], -up_max, dn_max)
        self.velocity_setpoint = tuple(v if c else NAN for v, c in zip(vel_sp, controlled))
        return vel_sp, controlled

    def _acceleration_setpoint(self, sp, now_s):
        p = self.params
        vel_sp, controlled = self._velocity_setpoint(sp, now_s)
        gains = (p['MPC_XY_VEL_P_ACC'], p['MPC_XY_VEL_P_ACC'], p['MPC_Z_VEL_P_ACC'])
        acc = [0.0, 0.0, 0.0]
        for i in range(3):
            ff = sp.acceleration[i] if _is(sp.acceleration[i]) else 0.0
            acc[i] = ff + (gains[i] * (vel_sp[i] - self.velocity[i]) if controlled[i] else 0.0)
        tilt_acc = GRAVITY * math.tan(math.radians(p['MPC_TILTMAX_AIR']))
        acc[0], acc[1] = _limit_xy(acc[0], acc[1], tilt_acc)
        acc[2] = _clamp(acc[2], -p['MPC_ACC_UP_MAX'], p['MPC_ACC_DOWN_MAX'])
        return acc

    def step(self, dt, sp, now_s):
        """Advance the model by dt seconds, flying setpoint `sp` when the motors allow."""
        flying = self.spooled_up(now_s)
        if flying:
            acc_cmd = self._acceleration_setpoint(sp, now_s)
            yaw_sp = sp.yaw if _is(sp.yaw) else self.yaw
            if _is(sp.yaw):
                yaw_rate = YAW_P * math.atan2(math.sin(yaw_sp - self.yaw), math.cos(yaw_sp - self.yaw))
            else:
                yaw_rate = sp.yaw_rate if _is(sp.yaw_rate) else 0.0
            self.yaw_rate = _clamp(yaw_rate, -YAW_RATE_MAX, YAW_RATE_MAX)
            self.setpoint, self.acceleration_setpoint = sp, acc_cmd
        else:
            # motors off or idling: no lift; in the air that is a fall
            acc_cmd = [0.0, 0.0, GRAVITY] if not self.ground_contact else [0.0, 0.0, 0.0]
            self.yaw_rate = 0.0
            self.setpoint, self.acceleration_setpoint = None, None
        alpha = min(1.0, dt / ACC_LAG_S) if flying else 1.0
        for i in range(3):
            self.acceleration[i] += alpha * (acc_cmd[i] - self.acceleration[i])
            self.velocity[i] += self.acceleration[i] * dt
            self.position[i] += self.velocity[i] * dt
        self.yaw = math.atan2(math.sin(self.yaw + self.yaw_rate * dt), math.cos(self.yaw + self.yaw_rate * dt))
        self._ground(now_s)
        self._attitude = None

    def _ground(self, now_s):
        if self.position[2] >= 0.0 and (self.velocity[2] >= 0.0 or self.acceleration[2] >= 0.0):
            # touching down or resting: the ground takes the load and stops the vehicle
            self.position[2] = 0.0
            self.velocity = [0.0, 0.0, 0.0]
            self.acceleration = [min(a, 0.0) if i == 2 else 0.0 for i, a in enumerate(self.acceleration)]
            if not self.ground_contact:
                self.ground_contact, self.contact_since_s = True, now_s
        elif self.position[2] < -0.02:
            self.ground_contact, self.contact_since_s = False, None
        if self.ground_contact and now_s - self.contact_since_s >= LANDED_AFTER_S:
            self.landed = True
        elif self.position[2] < -AIRBORNE_HEIGHT_M:
            self.landed = False

    # -- derived quantities ---------------------------------------------------------------

    def attitude(self):
        """(w, x, y, z) NED/FRD quaternion."""
        if self._attitude is None:
            self._attitude = quaternion_from_thrust(self.acceleration, self.yaw)
        return self._attitude

    def specific_force_body(self):
        """What an accelerometer reads (m/s^2, FRD): acceleration minus gravity, in body axes."""
        w, x, y, z = self.attitude()
        f = (self.acceleration[0], self.acceleration[1], self.acceleration[2] - GRAVITY)
        # rotate world->body: R^T f
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        return (r00 * f[0] + r10 * f[1] + r20 * f[2],
                r01 * f[0] + r11 * f[1] + r21 * f[2],
                r02 * f[0] + r12 * f[1] + r22 * f[2])

    def height(self):
        """Height above home (m, up positive)."""
        return -self.position[2]
