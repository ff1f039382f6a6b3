"""Navigator of the simulated PX4: the setpoints of the AUTO modes, as PX4's navigator makes them.

- AUTO.TAKEOFF: climb above the takeoff point to MIS_TAKEOFF_ALT (or the commanded
  altitude) at MPC_TKO_SPEED; within NAV_MC_ALT_RAD of it report `TakeoffComplete` (the
  commander loiters, at the takeoff altitude).
- AUTO.LOITER, and any mode without a setpoint of its own: hold where the mode began.
- AUTO.RTL, PX4's direct return: climb to the return altitude (RTL_RETURN_ALT above home,
  lower inside the RTL_CONE_ANG cone within RTL_MIN_DIST, never lower than now), return home at
  MPC_XY_CRUISE, descend to RTL_DESCEND_ALT, land.
- AUTO.LAND: descend where the mode began at PX4's landing speeds (`land_speed`).
- AUTO.MISSION: fly the mission items (`MissionRunner`), reporting reached items; waypoints
  are reached within NAV_ACC_RAD / NAV_MC_ALT_RAD and passed at PX4's corner speed.
Flights between points follow PX4's jerk-limited trajectory (sim.trajectory).
Altitudes are relative to `home` (local NED), which the flight stack sets at arming.
Pure: the vehicle model and the time are passed in; what must be said goes to `events`.
It neither decides modes (the commander does) nor flies (the vehicle model does).
"""

import math

from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import vehicle as vm
from offboard_py.sim.trajectory import Trajectory, corner_speed


NAV_COMMANDS = frozenset((mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME,
                          mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LAND,
                          mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH))
ABSOLUTE_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT))


def _dist_xy(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1])


def land_speed(params, height):
    """PX4's landing speed at `height` above the ground: MPC_Z_V_AUTO_DN above MPC_LAND_ALT1,
    blending to MPC_LAND_SPEED at MPC_LAND_ALT2, MPC_LAND_CRWL below MPC_LAND_ALT3 (the
    rangefinder sees the ground there)."""
    fast, slow = params['MPC_Z_V_AUTO_DN'], params['MPC_LAND_SPEED']
    alt1, alt2 = params['MPC_LAND_ALT1'], params['MPC_LAND_ALT2']
    if height >= alt1:
        speed = fast
    elif height <= alt2 or alt1 <= alt2:
        speed = slow
    else:
        speed = slow + (fast - slow) * (height - alt2) / (alt1 - alt2)
    if height < params['MPC_LAND_ALT3']:
        speed = min(speed, params['MPC_LAND_CRWL'])
    return min(speed, fast)


# Once the land detector feels the ground, PX4's landing keeps asking for more descent (its descent
# setpoint grows while the vehicle stands still: reference/conversations, takeoff-mavros-px4,
# POSITION_TARGET_LOCAL_NED at 63.5-64.5 s), which winds the thrust down to the land detector's
# minimal thrust (MINIMAL_THRUST_FRACTION, PX4's 10 %). The rate is fitted to the AUTO landings of
# reference/px4-sitl-measured.md (NAV_LAND from 2.2 m: 12.8 s; cmd/land from 5 m: 15.3 s): with it
# touchdown -> landed takes about 6 s after a slow final descent. The recorded RTL landings of the
# conversations took 3.3-3.5 s (a faster touchdown, a faster-growing setpoint); one rate cannot fit both.
LAND_PUSH_ACC = 0.03  # m/s^2
# The gimbal commands of a return left 0.16-0.4 s after its setpoint took over (reference/conversations:
# POSITION_TARGET_LOCAL_NED changed at 56.36-56.46 s and 56.76-56.96 s, COMMAND_LONG 1001 at 56.62 and 57.17 s),
# 1.29-1.37 s after the last setpoint
GIMBAL_DELAY_S = 0.25


def land_setpoint(params, xy, vehicle):
    """Descend over xy at PX4's landing speeds; on the ground, push down harder (LAND_PUSH_ACC)."""
    speed = land_speed(params, vehicle.height())
    pushed_s = vehicle.ground_contact_held_s()
    if pushed_s is not None:
        speed += LAND_PUSH_ACC * pushed_s
    return vm.setpoint(position=(xy[0], xy[1], vm.NAN), velocity=(vm.NAN, vm.NAN, speed), yaw=vehicle.yaw)


def rtl_return_height(params, distance):
    """PX4's return altitude above home from `distance` (m) away: RTL_RETURN_ALT; inside
    RTL_MIN_DIST no higher than the RTL_CONE_ANG cone; at least 2 NAV_ACC_RAD outside the
    acceptance radius, 2 x the distance inside it."""
    acceptance = params['NAV_ACC_RAD']
    height = params['RTL_RETURN_ALT']
    if distance <= acceptance:
        return 2.0 * distance
    cone = params['RTL_CONE_ANG']
    if cone > 0 and distance <= params['RTL_MIN_DIST']:
        half_angle = math.radians(min(max(cone, 1.0), 89.0))
        height = min(height, distance / math.tan(half_angle))
    return max(height, 2.0 * acceptance)


def rtl_return_down(params, position, home):
    """The altitude PX4's RTL returns at from `position`, as local z (NED): the return altitude
    for its distance from home, or where the vehicle is if higher (RTL never descends to return)."""
    distance = math.hypot(position[0] - home[0], position[1] - home[1])
    return min(home[2] - rtl_return_height(params, distance), position[2])


def rtl_time_estimate(params, position, home, landed, rtl=None):
    """PX4's estimate of the time a direct return home (RTL_TYPE 0, multicopter) takes from
    `position` (local NED), in s, or None when PX4 has none (landed: PX4's RTL starts idle; its
    estimate is then invalid). `rtl`: (phase, return altitude as local z) while AUTO.RTL flies,
    whose phase the estimate starts from; else it starts where PX4's RTL would: climbing (0 m
    when at or above the return altitude), then flying home. Climbs at MPC_Z_V_AUTO_UP, flies at
    MPC_XY_CRUISE, descends to RTL_DESCEND_ALT (or the return altitude, if lower), waits
    RTL_LAND_DELAY (a negative delay waits for good, and the landing is not counted), lands at
    MPC_Z_V_AUTO_DN (navigator's RtlDirect::calc_rtl_time_estimate with lib/rtl's estimator)."""
    if landed:
        return None
    height = home[2] - position[2]
    distance = math.hypot(position[0] - home[0], position[1] - home[1])
    phase, return_down = rtl if rtl is not None else ('climb', rtl_return_down(params, position, home))
    return_height = home[2] - return_down
    down_speed = params['MPC_Z_V_AUTO_DN']
    loiter_height = min(params['RTL_DESCEND_ALT'], return_height)
    time_s = 0.0
    if phase == 'climb':
        time_s += max(0.0, return_height - height) / params['MPC_Z_V_AUTO_UP']
        height = max(height, return_height)
    if phase in ('climb', 'return'):
        time_s += distance / params['MPC_XY_CRUISE']
    if phase != 'land':
        time_s += max(0.0, height - loiter_height) / down_speed
        height = min(height, loiter_height)
        if params['RTL_LAND_DELAY'] < 0:
            return time_s
        time_s += params['RTL_LAND_DELAY']
    return time_s + max(0.0, height) / down_speed


class Flyer:
    """What AUTO modes share: the trajectory towards a target, restarted from the vehicle's own
    state whenever the flight stops following it (a direct setpoint came in between)."""

    def __init__(self, params):
        self.params = params
        self.trajectory = None
        self._last_s = None

    def direct(self, sp):
        """A setpoint that does not follow the trajectory."""
        self.trajectory = None
        return sp

    def fly_to(self, vehicle, target, now_s, speed_at_target=0.0, xy_speed=None, up_speed=None):
        dt = 0.0 if self._last_s is None else max(0.0, now_s - self._last_s)
        self._last_s = now_s
        if self.trajectory is None:
            self.trajectory = Trajectory(vehicle.position, vehicle.velocity)
            dt = 0.0
        t = self.trajectory
        t.step(self.params, target, dt, vehicle.position, xy_speed=xy_speed, up_speed=up_speed,
               speed_at_target=speed_at_target)
        return vm.setpoint(position=t.position, velocity=t.velocity, acceleration=t.acceleration, yaw=vehicle.yaw)

    def take_off(self, vehicle, target, now_s):
        """PX4's takeoff: straight at the target while the takeoff ramp limits the climb, then the
        trajectory at MPC_TKO_SPEED (which brakes early for a low target)."""
        if vehicle.takeoff_state != 'flight':
            return self.direct(vm.setpoint(position=target, yaw=vehicle.yaw, z_up_max=self.params['MPC_TKO_SPEED']))
        return self.fly_to(vehicle, target, now_s, up_speed=self.params['MPC_TKO_SPEED'])


class MissionRunner:
    """Flies mission items: NAV_TAKEOFF, NAV_WAYPOINT (acceptance radius, hold time), NAV_LOITER_TIME,
    NAV_LOITER_UNLIM, NAV_LAND and NAV_RETURN_TO_LAUNCH; other items (DO_*) are passed over."""

    def __init__(self, params, frame):
        self.params, self.frame = params, frame
        self.flyer = Flyer(params)
        self.home = (0.0, 0.0, 0.0)
        self.items = []
        self.seq = 0
        self.reached = []        # seq numbers reached since the last take_reached()
        self.finished = False
        self._arrived_s = None   # when the current item's position was reached
        self._hold_point = None
        self._takeoff_xy = None
        self._previous = None    # where the flight to the current item began (for corner speeds)
        self.landed_at_end = False  # the mission ended with a landing, and the vehicle is down

    def load(self, items, seq=0):
        self.items, self.seq, self.finished, self.landed_at_end = list(items), seq, False, False
        self._arrived_s = self._hold_point = self._takeoff_xy = self._previous = None

    def set_current(self, seq):
        if 0 <= seq < len(self.items):
            self.seq, self.finished, self._arrived_s, self.landed_at_end = seq, False, None, False
            return True
        return False

    def restart_if_finished(self):
        self.set_current(self.seq if not self.finished else 0)

    def take_reached(self):
        reached, self.reached = self.reached, []
        return reached

    def _target(self, it, vehicle):
        """Local NED target of a positional item (the vehicle's own where the item leaves it open)."""
        if it.frame == mavlink.MAV_FRAME_LOCAL_NED:
            return (it.x, it.y, it.z)
        if it.frame == mavlink.MAV_FRAME_MISSION:
            return tuple(vehicle.position)
        if it.x == 0.0 and it.y == 0.0:  # no position given: here
            north, east = vehicle.position[0], vehicle.position[1]
        else:
            north, east, _ = self.frame.to_local(it.x, it.y, self.frame.alt0)
        if it.frame in ABSOLUTE_FRAMES:
            down = self.frame.alt0 - it.z
        else:  # relative to home (terrain frames are treated as relative: flat ground)
            down = self.home[2] - it.z
        return (north, east, down)

    def _next_target(self, vehicle):
        """The position of the next positional item after the current one, or None."""
        for it in self.items[self.seq + 1:]:
            if it.command in (mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LAND):
                return self._target(it, vehicle)
            if it.command in NAV_COMMANDS:
                return None
        return None

    def _advance(self, vehicle=None):
        self.reached.append(self.seq)
        self._arrived_s = None
        if vehicle is not None:
            it = self.items[self.seq]
            self._previous = self._target(it, vehicle) if it.command != mavlink.MAV_CMD_NAV_TAKEOFF \
                else tuple(vehicle.position)
        if self.seq + 1 < len(self.items):
            self.seq += 1
        else:
            self.finished = True

    def setpoint(self, vehicle, now_s):
        """The setpoint for now; reached items are recorded in `reached`."""
        p = self.params
        for _ in range(len(self.items)):  # pass over DO_* items in one go
            if self.finished or not self.items or self.items[self.seq].command in NAV_COMMANDS:
                break
            self._advance()
        if self.finished or not self.items:
            if self._hold_point is None:
                self._hold_point = tuple(vehicle.position)
            return self.flyer.direct(vm.hold(self._hold_point, vehicle.yaw))
        self._hold_point = None
        it = self.items[self.seq]
        pos = vehicle.position
        if it.command == mavlink.MAV_CMD_NAV_TAKEOFF:
            target = self._target(it, vehicle)
            if self._takeoff_xy is None:
                self._takeoff_xy = (pos[0], pos[1])
            north, east = self._takeoff_xy
            down = target[2] if target[2] < self.home[2] - 0.5 else self.home[2] - p['MIS_TAKEOFF_ALT']
            if abs(pos[2] - down) <= p['NAV_MC_ALT_RAD']:
                self._takeoff_xy = None
                self._advance(vehicle)
            return self.flyer.take_off(vehicle, (north, east, down), now_s)
        if it.command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._fly_then_land((self.home[0], self.home[1]), vehicle, now_s)
        target = self._target(it, vehicle)
        if it.command == mavlink.MAV_CMD_NAV_LAND:
            return self._fly_then_land(target, vehicle, now_s)
        radius = it.param2 if it.command == mavlink.MAV_CMD_NAV_WAYPOINT and it.param2 > 0 else p['NAV_ACC_RAD']
        hold_s = max(it.param1, 0.0) if it.command in (mavlink.MAV_CMD_NAV_WAYPOINT,
                                                         mavlink.MAV_CMD_NAV_LOITER_TIME) else None
        corner = 0.0 if hold_s is None or hold_s > 0.0 else corner_speed(p, self._previous, target,
                                                                         self._next_target(vehicle))
        if self._arrived_s is None and (_dist_xy(pos, target) <= radius
                                        and abs(pos[2] - target[2]) <= p['NAV_MC_ALT_RAD']):
            self._arrived_s = now_s
        if self._arrived_s is not None and hold_s is not None and now_s - self._arrived_s >= hold_s:
            self._advance(vehicle)
        return self.flyer.fly_to(vehicle, target, now_s, speed_at_target=corner)

    def _fly_then_land(self, target, vehicle, now_s):
        pos = vehicle.position
        if _dist_xy(pos, target) > self.params['NAV_ACC_RAD'] and not vehicle.landed:
            return self.flyer.fly_to(vehicle, (target[0], target[1], pos[2] if self.flyer.trajectory is None
                                               else self.flyer.trajectory.position[2]), now_s)
        if vehicle.landed:
            self._advance()
            self.finished = self.landed_at_end = True
            return self.flyer.direct(vm.hold((target[0], target[1], vehicle.ground_z), vehicle.yaw))
        return self.flyer.direct(land_setpoint(self.params, target, vehicle))


class NavigatorMode:
    """One AUTO mode of the navigator, as PX4 gives each its own class (navigator/takeoff.cpp,
    land.cpp, rtl.cpp, mission.cpp, loiter.cpp): on_activation() when the mode begins to fly,
    setpoint() every step, landing() for EXTENDED_SYS_STATE. `nav` is the Navigator (the vehicle,
    the parameters, home, the hold point and the events)."""

    def __init__(self, nav):
        self.nav = nav

    def on_activation(self):
        pass

    def on_inactivation(self):
        pass

    def setpoint(self, armed, now_s):
        return vm.hold(self.nav.hold_point, self.nav.hold_yaw)

    def landing(self):
        return False


class Loiter(NavigatorMode):
    """AUTO.LOITER, and any mode without a setpoint of its own: hold where the mode began (after a
    takeoff, at the takeoff altitude)."""

    def __init__(self, nav):
        super().__init__(nav)
        self.after_takeoff = None  # where to hold once a takeoff completes

    def on_activation(self):
        if self.after_takeoff is not None:
            self.nav.hold_point = self.after_takeoff


class Takeoff(NavigatorMode):
    """AUTO.TAKEOFF: climb above the takeoff point to its altitude; report TakeoffComplete within
    NAV_MC_ALT_RAD, and have the loiter that follows hold there."""

    def __init__(self, nav):
        super().__init__(nav)
        self.target = None  # local NED

    def on_activation(self):
        nav, v = self.nav, self.nav.vehicle
        if self.target is None:
            self.target = (v.position[0], v.position[1], nav.home[2] - nav.params['MIS_TAKEOFF_ALT'])

    def on_inactivation(self):
        self.target = None

    def setpoint(self, armed, now_s):
        nav, v = self.nav, self.nav.vehicle
        if self.target is None:
            return super().setpoint(armed, now_s)
        if armed and abs(v.position[2] - self.target[2]) <= nav.params['NAV_MC_ALT_RAD']:
            nav.events.append(ev.TakeoffComplete())
            nav.loiter.after_takeoff = self.target  # PX4 loiters at the takeoff altitude
            return nav.flyer.direct(vm.hold(self.target, nav.hold_yaw))
        return nav.flyer.take_off(v, self.target, now_s)


class Land(NavigatorMode):
    """AUTO.LAND: descend where the mode began at PX4's landing speeds."""

    def __init__(self, nav):
        super().__init__(nav)
        self.xy = None

    def on_activation(self):
        v = self.nav.vehicle
        self.xy = (v.position[0], v.position[1])

    def setpoint(self, armed, now_s):
        return land_setpoint(self.nav.params, self.xy, self.nav.vehicle)

    def landing(self):
        return True


class Rtl(NavigatorMode):
    """AUTO.RTL, PX4's direct return: climb to the return altitude, return home at MPC_XY_CRUISE,
    descend to RTL_DESCEND_ALT without stopping, land."""

    def __init__(self, nav):
        super().__init__(nav)
        self.phase = None
        self.down = None  # the return altitude as local z

    def on_activation(self):
        nav = self.nav
        self.down = rtl_return_down(nav.params, nav.vehicle.position, nav.home)
        self.phase = 'climb'

    def landing(self):
        return self.phase in ('descend', 'land')

    def setpoint(self, armed, now_s):
        nav = self.nav
        v, p, home, f = nav.vehicle, nav.params, nav.home, nav.flyer
        pos = v.position
        if self.phase == 'climb':
            if pos[2] <= self.down + p['NAV_MC_ALT_RAD']:
                self.phase = 'return'
            else:
                return f.fly_to(v, (nav.hold_point[0], nav.hold_point[1], self.down), now_s)
        if self.phase == 'return':
            if math.hypot(pos[0] - home[0], pos[1] - home[1]) <= p['NAV_ACC_RAD']:
                self.phase = 'descend'
            else:
                return f.fly_to(v, (home[0], home[1], self.down), now_s)
        if self.phase == 'descend':
            descend_down = home[2] - p['RTL_DESCEND_ALT']
            if pos[2] >= descend_down - p['NAV_MC_ALT_RAD']:
                self.phase = 'land'
            else:
                # no stop at RTL_DESCEND_ALT: the landing goes on at the landing speed there
                return f.fly_to(v, (home[0], home[1], descend_down), now_s,
                                speed_at_target=land_speed(p, p['RTL_DESCEND_ALT']))
        if v.landed:
            nav._idle_on_landing()
        return f.direct(land_setpoint(p, (home[0], home[1]), v))


class Mission(NavigatorMode):
    """AUTO.MISSION: fly the mission's items (MissionRunner), reporting those reached."""

    def on_activation(self):
        nav = self.nav
        nav.mission.restart_if_finished()
        nav.events.append(ev.MissionCurrent(nav.mission.seq))

    def setpoint(self, armed, now_s):
        nav = self.nav
        if not armed:
            return super().setpoint(armed, now_s)
        sp = nav.mission.setpoint(nav.vehicle, now_s)
        for seq in nav.mission.take_reached():
            nav.events.append(ev.ItemReached(seq))
            if not nav.mission.finished:
                nav.events.append(ev.MissionCurrent(nav.mission.seq))
        return sp


class Navigator:
    """The setpoint of the AUTO modes (and the hold of modes without one) for the mode flying now:
    one NavigatorMode per AUTO mode, the hold for the others."""

    def __init__(self, params, frame, vehicle):
        self.params, self.vehicle = params, vehicle
        self.mission = MissionRunner(params, frame)
        self.flyer = Flyer(params)
        self.events = []
        self.home = (0.0, 0.0, 0.0)
        self.hold_point = tuple(vehicle.position)
        self.hold_yaw = vehicle.yaw
        self.loiter = Loiter(self)
        self.takeoff = Takeoff(self)
        self.rtl = Rtl(self)
        self.modes = {'AUTO.LOITER': self.loiter, 'AUTO.TAKEOFF': self.takeoff, 'AUTO.LAND': Land(self),
                      'AUTO.RTL': self.rtl, 'AUTO.MISSION': Mission(self)}
        self.hold = NavigatorMode(self)  # the modes without a setpoint of their own
        self.active = self.hold
        self._idle_sent = False  # the return's idle item went out for this landing

    @property
    def home(self):
        return self._home

    @home.setter
    def home(self, home):
        self._home = tuple(home)
        self.mission.home = self._home

    @property
    def rtl_phase(self):
        return self.rtl.phase

    @property
    def rtl_down(self):
        return self.rtl.down

    # -- what the commander decided ------------------------------------------------------------

    def on_mode(self, mode):
        """A new mode is flying: remember where it began, and start its navigator mode."""
        v = self.vehicle
        self.hold_point = (v.position[0], v.position[1], min(v.position[2], v.ground_z))
        self.hold_yaw = v.yaw
        self.flyer.direct(None)
        if mode in ('AUTO.LAND', 'AUTO.RTL'):
            self._gimbal_neutral()
            self._idle_sent = False
        new = self.modes.get(mode, self.hold)
        for other in self.modes.values():
            if other is not new:
                other.on_inactivation()
        new.on_activation()
        self.loiter.after_takeoff = None
        self.active = new

    def _gimbal_neutral(self):
        """PX4's Land and RTL activation: take the gimbal, point it neutral, let it go (navigator's
        acquire_gimbal_control, set_gimbal_neutral, release_gimbal_control), as recorded in the
        failsafe's return (reference/conversations: COMMAND_LONG 1001 (1, 1, -1, -1), 1000 (NaN x4,
        flags NEUTRAL), 1001 (-3, -3, -1, -1); only the first repeated), GIMBAL_DELAY_S after the
        return's setpoint took over."""
        nan = vm.NAN
        self.events.append(ev.VehicleCommand(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE,
                                             (1.0, 1.0, -1.0, -1.0, 0.0, 0.0, 0.0), True, GIMBAL_DELAY_S))
        self.events.append(ev.VehicleCommand(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
                                             (nan, nan, nan, nan, float(mavlink.GIMBAL_MANAGER_FLAGS_NEUTRAL),
                                              0.0, 0.0), False, GIMBAL_DELAY_S))
        self.events.append(ev.VehicleCommand(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE,
                                             (-3.0, -3.0, -1.0, -1.0, 0.0, 0.0, 0.0), False, GIMBAL_DELAY_S))

    def _idle_on_landing(self):
        """PX4's return, once landed, sets its idle item and publishes it as a vehicle command: command
        0 (NAV_CMD_IDLE) with the mission item's fields (acceptance radius NAV_ACC_RAD, loiter radius
        NAV_LOITER_RAD, yaw NaN, the home altitude AMSL), recorded at the landing in both conversations
        (COMMAND_LONG 0 (0, 2, 80, NaN, 0, 0, 490.27), repeated)."""
        if self._idle_sent:
            return
        self._idle_sent = True
        p = self.params
        home_amsl = self.mission.frame.alt0 - self.home[2]
        self.events.append(ev.VehicleCommand(0, (0.0, p['NAV_ACC_RAD'], p['NAV_LOITER_RAD'], vm.NAN, 0.0, 0.0,
                                                 home_amsl), True))

    def on_armed(self, mode):
        self.hold_point = tuple(self.vehicle.position)
        if mode == 'AUTO.MISSION':
            self.mission.restart_if_finished()

    def takeoff_height(self, altitude_amsl, home_alt):
        """NAV_TAKEOFF's altitude as a height above home, or MIS_TAKEOFF_ALT when it is NaN or too low."""
        if math.isfinite(altitude_amsl):
            wanted = altitude_amsl - home_alt
            if wanted > self.home[2] - self.vehicle.position[2] + 0.5:
                return wanted
            self.events.append(ev.StatusText(mavlink.MAV_SEVERITY_WARNING,
                                             'Takeoff altitude below the vehicle, using MIS_TAKEOFF_ALT'))
        return self.params['MIS_TAKEOFF_ALT']

    def set_takeoff_height(self, height):
        v = self.vehicle
        self.takeoff.target = (v.position[0], v.position[1], self.home[2] - height)

    def load_mission(self, items, flying_it):
        self.mission.load(items)
        if flying_it:
            self.events.append(ev.MissionCurrent(0))

    def landing(self, mode):
        """Whether the vehicle is landing in `mode` (EXTENDED_SYS_STATE's LANDING)."""
        return self.modes.get(mode, self.hold).landing()

    # -- the setpoint ------------------------------------------------------------------------

    def setpoint(self, mode, armed, now_s):
        return self.modes.get(mode, self.hold).setpoint(armed, now_s)
