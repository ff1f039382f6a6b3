"""PX4's multicopter position control for the simulated vehicle (mc_pos_control: PositionControl and
TakeoffHandling), as the vehicle model's docstring (sim.vehicle) describes it: position error ->
velocity setpoint -> acceleration by a PID with PX4's anti-windup -> a thrust vector limited in
tilt and magnitude; the takeoff's spool-up and climb-rate ramp. It reads the parameters every step
and the estimate it is given; the airframe (sim.vehicle) flies the thrust it asks for.
"""

import math

from offboard_py.sim.flight_math import GRAVITY, NAN, clamp, is_set, limit_xy

TILT_LIMIT_SLEW = 0.2     # rad/s: how fast PX4 lets the tilt limit change (_tilt_limit_slew_rate)
TAKEOFF_TRIGGER_M = 0.2   # a position setpoint this far above asks for a takeoff (PX4)


class PositionControl:
    def __init__(self, params):
        self.params = params
        self.takeoff_state = 'disarmed'  # PX4's TakeoffHandling: disarmed, spoolup, ready, rampup, flight
        self.ramp_vz = 0.0            # takeoff ramp: the climb-rate limit now (m/s, up positive)
        self.integral = [0.0, 0.0, 0.0]
        # PX4 limits the tilt to MPC_TILTMAX_LND until the takeoff is over, then lets the limit
        # grow to MPC_TILTMAX_AIR at TILT_LIMIT_SLEW rad/s (MulticopterPositionControl)
        self.tilt_limit = math.radians(params['MPC_TILTMAX_LND'])
        # what it tracks, for telemetry (POSITION_TARGET_LOCAL_NED, ATTITUDE_TARGET): the velocity
        # setpoint it gave (NaN where not controlled) and the commanded acceleration (None: not flying)
        self.velocity_setpoint = (NAN, NAN, NAN)
        self.acceleration_setpoint = None

    def arm(self, landed):
        self.takeoff_state = 'spoolup' if landed else 'flight'
        self.integral = [0.0, 0.0, 0.0]

    def disarm(self):
        self.takeoff_state = 'disarmed'
        self.integral = [0.0, 0.0, 0.0]

    def flying(self):
        return self.takeoff_state in ('rampup', 'flight')

    def hold(self):
        """Motors off or idling: the controller held (PX4 resets its integrals until the ramp)."""
        self.integral = [0.0, 0.0, 0.0]
        self.acceleration_setpoint = None
        self.velocity_setpoint = (NAN, NAN, NAN)

    # -- PX4's takeoff handling --------------------------------------------------------------

    def update_takeoff(self, sp, dt, climb_speed, spooled_up, estimate_z, landed):
        p, state = self.params, self.takeoff_state
        if state == 'spoolup' and spooled_up:
            state = 'ready'
        if state == 'ready':
            z = estimate_z
            wants = ((is_set(sp.position[2]) and sp.position[2] < z - TAKEOFF_TRIGGER_M)
                     or (is_set(sp.velocity[2]) and not is_set(sp.position[2]) and sp.velocity[2] < -TAKEOFF_TRIGGER_M))
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
        if state == 'flight' and landed:
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
        vel_sp[0], vel_sp[1] = limit_xy(vel_sp[0], vel_sp[1], xy_max)
        low = -up_max
        vel_sp[2] = clamp(vel_sp[2], low, max(dn_max, low))
        self.velocity_setpoint = (vel_sp[0] if controlled[0] else NAN, vel_sp[1] if controlled[1] else NAN,
                                  vel_sp[2] if controlled[2] else NAN)
        return vel_sp, controlled

    def thrust(self, sp, estimate, achieved, dt):
        """PX4's PositionControl: the normalised thrust vector (NED) for setpoint `sp`, from the
        estimate (position, velocity) and the achieved acceleration (the D term's)."""
        p = self.params
        pos, vel = estimate
        vel_sp, controlled = self._velocity_setpoint(sp, pos)
        xy_p, z_p = p['MPC_XY_VEL_P_ACC'], p['MPC_Z_VEL_P_ACC']
        gains_i = (p['MPC_XY_VEL_I_ACC'], p['MPC_XY_VEL_I_ACC'], p['MPC_Z_VEL_I_ACC'])
        gains_d = (p['MPC_XY_VEL_D_ACC'], p['MPC_XY_VEL_D_ACC'], p['MPC_Z_VEL_D_ACC'])
        error = [vel_sp[0] - vel[0] if controlled[0] else 0.0, vel_sp[1] - vel[1] if controlled[1] else 0.0,
                 vel_sp[2] - vel[2] if controlled[2] else 0.0]
        acc = [0.0, 0.0, 0.0]
        sp_acc, integral = sp.acceleration, self.integral
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
        self.tilt_limit += clamp(math.radians(wanted) - self.tilt_limit, -step, step)
        tilt_max = self.tilt_limit
        if math.acos(clamp(bz, -1.0, 1.0)) > tilt_max:
            horizontal = math.hypot(bx, by)
            bx, by, bz = bx / horizontal * math.sin(tilt_max), by / horizontal * math.sin(tilt_max), math.cos(tilt_max)
        collective = (acc[2] * hover / GRAVITY - hover) / bz
        collective = min(collective, -thr_min)
        thrust = [bx * collective, by * collective, bz * collective]
        # saturation: vertical first, what is left for the horizontal
        if thrust[2] < -thr_max:
            thrust[2] = -thr_max
        xy_room = math.sqrt(max(thr_max * thr_max - thrust[2] * thrust[2], 0.0))
        thrust[0], thrust[1] = limit_xy(thrust[0], thrust[1], xy_room)
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
        integral[2] = clamp(integral[2], -GRAVITY, GRAVITY)
        self.acceleration_setpoint = acc
        return thrust
