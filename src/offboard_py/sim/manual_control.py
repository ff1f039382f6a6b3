"""PX4's manual flight modes for the simulated PX4: a ground station's MANUAL_CONTROL sticks flown as PX4 flies them.

- The sticks (`ManualControlSetpoint`, PX4's manual_control_setpoint_s: roll, pitch, yaw, throttle, each -1..1)
  come from MANUAL_CONTROL as src/modules/mavlink/mavlink_receiver.cpp (handle_message_manual_control) scales
  them: x -> pitch, y -> roll, r -> yaw by 1/1000, z 0..1000 -> throttle -1..1 (500 the centre); a field
  out of its range is left at 0 (`from_mavlink`).
- POSCTL with MPC_POS_MODE 4 (PX4 SITL's default, and what FlightModeManager flies for any value but 0 and 3; PX4's
  older position modes 0 and 3, and ALTCTL's unsmoothed task of MPC_POS_MODE 0, are flown as 4 here):
  FlightTaskManualAcceleration
  (src/modules/flight_mode_manager/tasks/ManualAcceleration). The roll/pitch sticks (MAN_DEADZONE and PX4's
  0.6 expo, lib/sticks/Sticks.hpp) ask for a horizontal acceleration up to 2 x MPC_ACC_HOR, less a drag that
  holds the speed at MPC_VEL_MANUAL and brakes harder with the sticks centred, jerk-limited by MPC_JERK_MAX,
  within the takeoff's tilt limit; the position is locked once the velocity setpoint is zero
  (tasks/Utility/StickAccelerationXY.cpp). Vertical and yaw as in ALTCTL.
- ALTCTL: FlightTaskManualAltitudeSmoothVel (tasks/ManualAltitude, ManualAltitudeSmoothVel,
  lib/motion_planning/ManualVelocitySmoothingZ and VelocitySmoothing): the throttle stick asks for a climb up to
  MPC_Z_VEL_MAX_UP or a descent up to MPC_Z_VEL_MAX_DN, smoothed by MPC_ACC_UP_MAX / MPC_ACC_DOWN_MAX and
  MPC_JERK_MAX, slowed near the ground (MPC_TKO_SPEED / MPC_LAND_SPEED below MPC_LAND_ALT2, blending up to
  MPC_LAND_ALT1, by the height above the ground: SIH's rangefinder's distance); centred, the altitude is locked
  where the smoothed climb stops. The roll/pitch sticks tilt the vehicle up to MPC_MAN_TILT_MAX
  (tasks/Utility/StickTiltXY.cpp, filtered by MC_MAN_TILT_TAU). A throttle above 0.3 (65 %) asks for a takeoff
  (FlightTaskManualAltitude::_checkTakeoff).
- The yaw stick: a yaw rate up to MPC_MAN_Y_MAX, filtered by MPC_MAN_Y_TAU; the heading is locked once it is
  zero (lib/stick_yaw/StickYaw.cpp; without an unaided heading, as the simulator has none).
- MANUAL and STABILIZED: mc_att_control's generate_attitude_setpoint (src/modules/mc_att_control/
  mc_att_control_main.cpp): roll and pitch sticks tilt by up to MPC_MAN_TILT_MAX, the yaw stick as above, the
  throttle through PX4's throttle curve (MPC_THR_CURVE 0: MPC_MANTHR_MIN at the bottom, the hover thrust
  estimate at the centre, MPC_THR_MAX at the top; the estimate is the thrust that holds SIH's airframe, and the
  minimum is not slewed in after arming).
What a mode asks is a vehicle setpoint (sim.vehicle.setpoint), which the vehicle's controller flies. Before
the takeoff the controller takes a takeoff from a climb asked for (sim.position_control); PX4's manual modes
ask for it with the throttle only, so the setpoint says so then (`_takeoff_handling`).
Terrain hold (MPC_ALT_MODE 2) is the altitude lock over the simulator's flat ground. ACRO, POSCTL.SLOW and
ALTITUDE_CRUISE are not flown from the sticks (the navigator's hold, as without MANUAL_CONTROL), nor are PX4's
stick gestures (arming, disarming, RC override of the AUTO modes) taken.
Held to real PX4 SITL SIH flying a ground station's sticks: reference/px4-sitl-manual-control.json.
Pure: the sticks, the vehicle model and the time are passed in; no MAVLink, no clock.
"""

import math
from typing import NamedTuple

from offboard_py.sim import vehicle as vm
from offboard_py.sim.flight_math import (GRAVITY, NAN, alpha_filter, clamp, expo_deadzone, interpolate, is_set,
                                         quaternion_product, wrap_pi)
from offboard_py.sim.position_control import TAKEOFF_TRIGGER_M
from offboard_py.sim.sticks import (StickAccelerationXY, StickYaw, limit_unit_length, maximum_tilt_acceleration,
                                    rotate_into_heading)
from offboard_py.sim.velocity_smoothing import ManualVelocitySmoothingZ

STICK_EXPO = 0.6            # Sticks::get*Expo's default expo
TAKEOFF_THROTTLE = 0.3      # FlightTaskManualAltitude::_checkTakeoff: the throttle stick above 65 %
FLOWN_MODES = frozenset(('POSCTL', 'ALTCTL', 'STABILIZED', 'MANUAL'))


class ManualControlSetpoint(NamedTuple):
    """PX4's manual_control_setpoint_s: the sticks, each -1..1 (throttle 0 at the centre)."""
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0
    throttle: float = 0.0


CENTRED = ManualControlSetpoint()  # what PX4's Sticks read without manual control


def from_mavlink(x, y, z, r):
    """MANUAL_CONTROL's fields as mavlink_receiver.cpp's handle_message_manual_control scales them; a field
    out of range (x, y, r outside -1000..1000, z outside 0..1000) stays 0."""
    def axis(value):
        return value / 1000.0 if -1000 <= value <= 1000 else 0.0
    throttle = z / 500.0 - 1.0 if 0 <= z <= 1000 else 0.0
    return ManualControlSetpoint(roll=axis(y), pitch=axis(x), yaw=axis(r), throttle=throttle)


def _last(value, fallback):
    return value if is_set(value) else fallback


class ManualAltitude:
    """ALTCTL: FlightTaskManualAltitudeSmoothVel (module docstring). `setpoint()` gives PX4's trajectory
    setpoint as a vehicle setpoint."""

    def __init__(self, params, vehicle):
        self.params = params
        position, velocity = vehicle.estimate
        last = vehicle.setpoint
        z = _last(last.position[2], position[2]) if last else position[2]
        vz = _last(last.velocity[2], velocity[2]) if last else velocity[2]
        az = _last(last.acceleration[2], 0.0) if last else 0.0
        self.smoothing = ManualVelocitySmoothingZ(az, vz, z)
        self.yaw = StickYaw(params)
        self.yaw_setpoint = NAN
        self.tilt_filtered = (0.0, 0.0)
        self.want_takeoff = False

    def _vertical(self, sticks, vehicle, dt):
        """(position z or NaN, velocity z, acceleration z) of the smoothed throttle."""
        p = self.params
        throttle = expo_deadzone(sticks.throttle, STICK_EXPO, p['MAN_DEADZONE'])
        speed_max = p['MPC_Z_VEL_MAX_DN'] if sticks.throttle < 0.0 else p['MPC_Z_VEL_MAX_UP']
        target = speed_max * -throttle
        # slowed near the ground: the takeoff and landing speeds below MPC_LAND_ALT2
        height = vehicle.height()
        alt1, alt2 = p['MPC_LAND_ALT1'], p['MPC_LAND_ALT2']
        limit_down = interpolate(height, alt2, alt1, p['MPC_LAND_SPEED'], p['MPC_Z_VEL_MAX_DN'])
        limit_up = interpolate(height, alt2, alt1, p['MPC_TKO_SPEED'], p['MPC_Z_VEL_MAX_UP'])
        target = clamp(target, -limit_up, limit_down)
        s = self.smoothing
        s.trajectory.max_jerk = p['MPC_JERK_MAX']
        s.max_accel_up, s.max_vel_up = p['MPC_ACC_UP_MAX'], p['MPC_Z_VEL_MAX_UP']
        s.max_accel_down, s.max_vel_down = p['MPC_ACC_DOWN_MAX'], p['MPC_Z_VEL_MAX_DN']
        s.update(dt, target, vehicle.estimate[0][2], vehicle.velocity_setpoint[2])
        return s.position_setpoint, s.trajectory.v, s.trajectory.a

    def _yaw(self, sticks, vehicle, dt):
        stick = expo_deadzone(sticks.yaw, STICK_EXPO, self.params['MAN_DEADZONE'])
        yaw_rate, self.yaw_setpoint = self.yaw.update(stick, vehicle.yaw, self.yaw_setpoint, dt)
        return yaw_rate

    def _horizontal(self, sticks, vehicle, dt):
        """StickTiltXY: the raw roll/pitch sticks as a horizontal acceleration (NED)."""
        x, y = limit_unit_length(sticks.pitch, sticks.roll)
        tau = self.params['MC_MAN_TILT_TAU']
        fx, fy = self.tilt_filtered
        self.tilt_filtered = (alpha_filter(fx, x, dt, tau), alpha_filter(fy, y, dt, tau))
        north, east = rotate_into_heading(*self.tilt_filtered, vehicle.yaw, self.yaw_setpoint)
        scale = maximum_tilt_acceleration(self.params)
        return (NAN, NAN), (NAN, NAN), (north * scale, east * scale)

    def setpoint(self, sticks, vehicle, dt):
        yaw_rate = self._yaw(sticks, vehicle, dt)
        z, vz, az = self._vertical(sticks, vehicle, dt)
        (x, y), (vx, vy), (ax, ay) = self._horizontal(sticks, vehicle, dt)
        self.want_takeoff = sticks.throttle > TAKEOFF_THROTTLE
        yaw = self.yaw_setpoint
        return vm.setpoint(position=(x, y, z), velocity=(vx, vy, vz), acceleration=(ax, ay, az), yaw=yaw,
                           yaw_rate=NAN if is_set(yaw) else yaw_rate)


class ManualAcceleration(ManualAltitude):
    """POSCTL with MPC_POS_MODE 4: FlightTaskManualAcceleration (module docstring)."""

    def __init__(self, params, vehicle):
        super().__init__(params, vehicle)
        last = vehicle.setpoint
        velocity = (last.velocity[0], last.velocity[1]) if last else (NAN, NAN)
        if not all(is_set(c) for c in velocity):
            velocity = vehicle.estimate[1][:2]
        acceleration = (last.acceleration[0], last.acceleration[1]) if last else (NAN, NAN)
        self.xy = StickAccelerationXY(params, velocity, acceleration)

    def _horizontal(self, sticks, vehicle, dt):
        dz = self.params['MAN_DEADZONE']
        stick_x = expo_deadzone(sticks.pitch, STICK_EXPO, dz)
        stick_y = expo_deadzone(sticks.roll, STICK_EXPO, dz)
        xy = self.xy
        xy.update(stick_x, stick_y, vehicle.yaw, self.yaw_setpoint, vehicle.estimate[0],
                  vehicle.velocity_setpoint[:2], vehicle.control.tilt_limit, dt)
        return tuple(xy.position), tuple(xy.velocity), tuple(xy.acceleration)


class Stabilized:
    """MANUAL and STABILIZED: mc_att_control's attitude and thrust from the sticks (module docstring)."""

    def __init__(self, params, vehicle):
        self.params = params
        self.yaw = StickYaw(params)
        self.yaw_setpoint = NAN
        self.tilt_filtered = (0.0, 0.0)
        self.want_takeoff = False

    def setpoint(self, sticks, vehicle, dt):
        p = self.params
        if sticks.throttle < -0.9:  # the arming gesture must not wind up a heading error
            self.yaw_setpoint = NAN
        stick_yaw = expo_deadzone(sticks.yaw, STICK_EXPO, p['MAN_DEADZONE'])
        yaw_rate, self.yaw_setpoint = self.yaw.update(stick_yaw, vehicle.yaw, self.yaw_setpoint, dt)
        tilt_max = math.radians(p['MPC_MAN_TILT_MAX'])
        tau = p['MC_MAN_TILT_TAU']
        roll = alpha_filter(self.tilt_filtered[0], sticks.roll * tilt_max, dt, tau)
        pitch = alpha_filter(self.tilt_filtered[1], sticks.pitch * tilt_max, dt, tau)
        self.tilt_filtered = (roll, pitch)
        # a rotation vector: roll about the body's x axis, the pitch stick forward tilts the nose down
        rx, ry = roll, -pitch
        angle = math.hypot(rx, ry)
        if angle > tilt_max:
            rx, ry, angle = rx * tilt_max / angle, ry * tilt_max / angle, tilt_max
        s = math.sin(angle / 2.0) / angle if angle > 0.0 else 0.5
        q_rp = (math.cos(angle / 2.0), rx * s, ry * s, 0.0)
        heading = self.yaw_setpoint if is_set(self.yaw_setpoint) else vehicle.yaw
        q_yaw = (math.cos(heading / 2.0), 0.0, 0.0, math.sin(heading / 2.0))
        attitude = quaternion_product(q_yaw, q_rp)
        # the vehicle turns its heading by MC_YAW_P times the error: a turning stick asks for its rate so
        yaw = heading if is_set(self.yaw_setpoint) else wrap_pi(vehicle.yaw + yaw_rate / vm.YAW_P)
        return vm.setpoint(attitude=attitude, thrust=throttle_curve(p, sticks.throttle), yaw=yaw)


def hover_thrust_estimate(params):
    """What PX4's hover thrust estimator converges to on SIH's airframe (the thrust that holds SIH_MASS with
    four rotors of SIH_T_MAX), within mc_att_control's 0.05..0.9."""
    return clamp(params['SIH_MASS'] * GRAVITY / (4.0 * max(params['SIH_T_MAX'], 1e-3)), 0.05, 0.9)


def throttle_curve(params, throttle):
    """mc_att_control's throttle_curve: the stick's -1, 0, 1 at MPC_MANTHR_MIN, the hover thrust and MPC_THR_MAX
    (MPC_THR_CURVE 0: the hover thrust estimate, 2: MPC_THR_HOVER); MPC_THR_CURVE 1: MPC_MANTHR_MIN to
    MPC_THR_MAX."""
    low, high = params['MPC_MANTHR_MIN'], params['MPC_THR_MAX']
    hover = params['MPC_THR_HOVER'] if params['MPC_THR_CURVE'] == 2 else hover_thrust_estimate(params)
    if params['MPC_THR_CURVE'] == 1:
        return interpolate(throttle, -1.0, 1.0, low, high)
    if throttle <= 0.0:
        return interpolate(throttle, -1.0, 0.0, low, hover)
    return interpolate(throttle, 0.0, 1.0, hover, high)


TASKS = {'POSCTL': ManualAcceleration, 'ALTCTL': ManualAltitude, 'STABILIZED': Stabilized, 'MANUAL': Stabilized}


class ManualControl:
    """The manual modes' setpoints for the flight stack: PX4's FlightModeManager starts the mode's task
    afresh at each mode change, from the setpoint flown until then."""

    def __init__(self, params):
        self.params = params
        self.mode = None
        self.task = None
        self._last_s = None

    def setpoint(self, nav_mode, sticks, vehicle, now_s):
        """The setpoint of manual mode `nav_mode` (one of FLOWN_MODES) for `sticks`."""
        if nav_mode != self.mode:
            self.mode, self.task, self._last_s = nav_mode, TASKS[nav_mode](self.params, vehicle), None
        dt = 0.0 if self._last_s is None else now_s - self._last_s
        self._last_s = now_s
        sp = self.task.setpoint(sticks, vehicle, dt)
        return self._takeoff_handling(sp, vehicle)

    def stop(self):
        """Another mode flies: the next manual mode starts afresh."""
        self.mode = self.task = None

    def _takeoff_handling(self, sp, vehicle):
        """Until the takeoff, PX4's manual modes ask for one with the throttle above TAKEOFF_THROTTLE only
        (the flight task's want_takeoff), which the controller (sim.position_control) takes from a climb."""
        if sp.attitude is not None:
            return sp
        if vehicle.takeoff_state == 'rampup':  # mc_pos_control: no acceleration feed-forward amends the ramp
            return sp._replace(acceleration=(sp.acceleration[0], sp.acceleration[1], NAN))
        if vehicle.takeoff_state not in ('spoolup', 'ready'):
            return sp
        vz = min(sp.velocity[2], -TAKEOFF_TRIGGER_M * 1.01) if self.task.want_takeoff else 0.0
        return sp._replace(position=(sp.position[0], sp.position[1], NAN),
                           velocity=(sp.velocity[0], sp.velocity[1], vz))
