"""The mission's items flown, as PX4's navigator Mission does: NAV_TAKEOFF, NAV_WAYPOINT (acceptance
radius, hold time, passed at PX4's corner speed), NAV_LOITER_TIME, NAV_LOITER_UNLIM, NAV_LAND, and
NAV_RETURN_TO_LAUNCH handed to the commander (AUTO.RTL); the reached items reported. Pure: the vehicle model and the time are passed in.

PX4 flies some items through work items of its own (src/modules/navigator/mission.cpp at 02e73e3b6f,
Mission::setActiveMissionItems, handleTakeoff, handleLanding; mission_base.cpp on_active):
- a vertical takeoff (do_need_vertical_takeoff) before a NAV_TAKEOFF, NAV_WAYPOINT, NAV_LOITER_TIME or
  NAV_LOITER_UNLIM item when the vehicle is landed, or in the air below the takeoff altitude with a
  NAV_TAKEOFF item (or still owing a takeoff: at the start, and after a landing item): straight up over
  where it stands to the item's altitude, at least MIS_TAKEOFF_ALT (calculate_takeoff_altitude: above
  the ground when landed, above home in the air), with "Takeoff to N meters above home"; reaching it is
  not reported, then the item itself is flown as a waypoint (a NAV_TAKEOFF item to its own position);
- before a NAV_LAND item further than NAV_ACC_RAD away (do_need_move_to_land), a waypoint over the
  landing point at the altitude flown now; reaching it reports the landing item reached, then the
  descent (a LAND setpoint: EXTENDED_SYS_STATE LANDING) follows.
The reached times and landed states of a mission without a takeoff item are recorded in
reference/traces/px4-sitl-mission-no-takeoff-item-{1,2}.csv (reference/px4-sitl-measured.md, "Turn 4").
"""

from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import vehicle as vm
from offboard_py.sim.flyer import Flyer, dist_xy, land_setpoint
from offboard_py.sim.trajectory import corner_speed

# NAV_RETURN_TO_LAUNCH is no item PX4's mission flies: mission_block.cpp issues it as a vehicle command
# (VEHICLE_CMD_NAV_RETURN_TO_LAUNCH: Commander switches to AUTO.RTL, "Returning to launch") and counts it
# reached at once (is_mission_item_reached_or_completed); the return is AUTO.RTL's, at RTL_RETURN_ALT
NAV_COMMANDS = frozenset((mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME,
                          mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LAND,
                          mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH))
ABSOLUTE_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT))
# The items PX4 takes off for first when a takeoff is owed (Mission::do_need_vertical_takeoff)
TAKEOFF_FIRST = frozenset((mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_WAYPOINT,
                           mavlink.MAV_CMD_NAV_LOITER_TIME, mavlink.MAV_CMD_NAV_LOITER_UNLIM))
# PX4's work items (MissionBase::WorkItemType) that this model flies; None is WORK_ITEM_TYPE_DEFAULT
TAKEOFF, MOVE_TO_LAND, LAND = 'takeoff', 'move_to_land', 'land'


class MissionRunner:
    """Flies mission items: NAV_TAKEOFF, NAV_WAYPOINT (acceptance radius, hold time), NAV_LOITER_TIME,
    NAV_LOITER_UNLIM and NAV_LAND; NAV_RETURN_TO_LAUNCH goes to the commander (`commands`); other items
    (DO_*) are passed over."""

    def __init__(self, params, origin):
        self.params, self.origin = params, origin
        self.flyer = Flyer(params)
        self.home = (0.0, 0.0, 0.0)
        self.items = []
        self.seq = 0
        self.reached = []        # seq numbers reached since the last take_reached()
        self.finished = False
        self._arrived_s = None   # when the current item's position was reached
        self._hold_point = None
        self._previous = None    # where the flight to the current item began (for corner speeds)
        self.landed_at_end = False  # the mission ended with a landing, and the vehicle is down
        self.work = None         # the work item flown for the current item (TAKEOFF, MOVE_TO_LAND, LAND)
        self._work_target = None
        self._entered = False    # the current item's work item has been chosen (setActiveMissionItems)
        self._land_reported = False  # the landing item was reported reached over its point
        self._need_takeoff = True  # MissionBase's _need_takeoff: owed at the start and after a landing
        self.texts = []          # (MAV_SEVERITY, text) for the pilot, taken by the navigator
        self.commands = []       # vehicle commands the items issue to the commander (ev.ReturnToLaunch)
        self.cruise_speed = None  # m/s a DO_CHANGE_SPEED set for the legs; None: MPC_XY_CRUISE

    def load(self, items, seq=0):
        self.items, self.seq, self.finished, self.landed_at_end = list(items), seq, False, False
        self.cruise_speed = None
        self._arrived_s = self._hold_point = self._previous = None
        self._enter()

    def set_current(self, seq):
        if 0 <= seq < len(self.items):
            self.seq, self.finished, self._arrived_s, self.landed_at_end = seq, False, None, False
            self._enter()
            return True
        return False

    def _enter(self):
        """The current item is new: its work item is chosen when it is first flown."""
        self.work = self._work_target = None
        self._entered = self._land_reported = False

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
            north, east, _ = self.origin.to_local(it.x, it.y, self.origin.alt0)
        if it.frame in ABSOLUTE_FRAMES:
            down = self.origin.alt0 - it.z
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
            self._enter()
        else:
            self.finished = True

    def setpoint(self, vehicle, now_s):
        """The setpoint for now; reached items are recorded in `reached`."""
        p = self.params
        for _ in range(len(self.items)):  # pass over DO_* items in one go
            if self.finished or not self.items or self.items[self.seq].command in NAV_COMMANDS:
                break
            self._do(self.items[self.seq])
            self._advance()
        if self.finished or not self.items:
            if self._hold_point is None:
                self._hold_point = tuple(vehicle.position)
            return self.flyer.direct(vm.hold(self._hold_point, vehicle.yaw))
        self._hold_point = None
        it = self.items[self.seq]
        if not self._entered:
            self._entered = True
            self._choose_work(it, vehicle)
        if self.work == TAKEOFF:
            if abs(vehicle.position[2] - self._work_target[2]) > p['NAV_MC_ALT_RAD']:
                return self.flyer.take_off(vehicle, self._work_target, now_s)
            self.work = None  # up: the item itself is flown now, as a waypoint (not reported)
            self._previous = tuple(vehicle.position)
        if it.command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            self.commands.append(ev.ReturnToLaunch())
            self._advance(vehicle)
            self._hold_point = tuple(vehicle.position)
            return self.flyer.direct(vm.hold(self._hold_point, vehicle.yaw))
        target = self._target(it, vehicle)
        if it.command == mavlink.MAV_CMD_NAV_LAND:
            return self._land(target, vehicle, now_s)
        radius = it.param2 if it.command == mavlink.MAV_CMD_NAV_WAYPOINT and it.param2 > 0 else p['NAV_ACC_RAD']
        hold_s = max(it.param1, 0.0) if it.command in (mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_TAKEOFF,
                                                         mavlink.MAV_CMD_NAV_LOITER_TIME) else None
        if it.command == mavlink.MAV_CMD_NAV_TAKEOFF:
            hold_s = 0.0
        corner = 0.0 if hold_s is None or hold_s > 0.0 else corner_speed(p, self._previous, target,
                                                                         self._next_target(vehicle))
        if self.cruise_speed is not None:
            corner = min(corner, self.cruise_speed)
        if self._reached(target, radius, vehicle) and self._arrived_s is None:
            self._arrived_s = now_s
        if self._arrived_s is not None and hold_s is not None and now_s - self._arrived_s >= hold_s:
            self._advance(vehicle)
        return self.flyer.fly_to(vehicle, target, now_s, speed_at_target=corner, xy_speed=self.cruise_speed)

    def _do(self, it):
        """A DO_* item, passed over at once (MissionBlock::is_mission_item_reached_or_completed) after it
        was issued as a vehicle command. DO_CHANGE_SPEED as navigator_main.cpp takes it: param2 > 0 is the
        cruise speed of the following legs (ground and air speed alike), anything else restores
        MPC_XY_CRUISE; FlightTaskAuto keeps the speed within MPC_XY_VEL_MAX."""
        if it.command == mavlink.MAV_CMD_DO_CHANGE_SPEED:
            speed = it.param2
            self.cruise_speed = min(speed, self.params['MPC_XY_VEL_MAX']) if speed > 1.2e-7 else None

    def _reached(self, target, radius, vehicle):
        pos = vehicle.position
        return dist_xy(pos, target) <= radius and abs(pos[2] - target[2]) <= self.params['NAV_MC_ALT_RAD']

    def _choose_work(self, it, vehicle):
        """Mission::handleTakeoff and handleLanding for a multicopter: the work item the current item
        begins with, if any."""
        p, pos = self.params, vehicle.position
        if it.command in TAKEOFF_FIRST:
            target = self._target(it, vehicle)
            # calculate_takeoff_altitude: at least MIS_TAKEOFF_ALT above the ground landed, above home flying
            base = pos[2] if vehicle.landed else self.home[2]
            down = min(target[2], base - p['MIS_TAKEOFF_ALT'])
            if vehicle.landed:
                self._need_takeoff = True
            elif pos[2] < down + p['NAV_MC_ALT_RAD']:  # above the takeoff altitude, less its acceptance
                self._need_takeoff = False
            elif it.command == mavlink.MAV_CMD_NAV_TAKEOFF:
                self._need_takeoff = True
            if self._need_takeoff:
                self._need_takeoff = False
                self.work, self._work_target = TAKEOFF, (pos[0], pos[1], down)
                self.texts.append((mavlink.MAV_SEVERITY_INFO,
                                   'Takeoff to %.1f meters above home' % (self.home[2] - down)))
        elif it.command == mavlink.MAV_CMD_NAV_LAND and not vehicle.landed:
            target = self._target(it, vehicle)
            if dist_xy(pos, target) > p['NAV_ACC_RAD']:  # do_need_move_to_land
                flown = self.flyer.trajectory.position[2] if self.flyer.trajectory is not None else pos[2]
                self.work, self._work_target = MOVE_TO_LAND, (target[0], target[1], flown)
            else:
                self.work = LAND

    def _land(self, target, vehicle, now_s):
        """A landing item: over the point first (reported reached there), then down; reached on the
        ground when no move was needed (MissionBlock::is_mission_item_reached_or_completed, NAV_CMD_LAND)."""
        if self.work == MOVE_TO_LAND:
            if not self._reached(self._work_target, self.params['NAV_ACC_RAD'], vehicle):
                return self.flyer.fly_to(vehicle, self._work_target, now_s, xy_speed=self.cruise_speed)
            self.reached.append(self.seq)
            self._land_reported = True
        self.work = LAND
        if vehicle.landed:
            if not self._land_reported:  # PX4 reports a seq reached once (mission_result.seq_reached)
                self.reached.append(self.seq)
            self._need_takeoff = True
            self.finished = self.landed_at_end = True
            self.work = None
            return self.flyer.direct(vm.hold((target[0], target[1], vehicle.ground_z), vehicle.yaw))
        return self.flyer.direct(land_setpoint(self.params, target, vehicle))

    def landing(self):
        """A LAND setpoint is flown (EXTENDED_SYS_STATE LANDING)."""
        return self.work == LAND and not self.finished

    def taking_off(self):
        """A TAKEOFF setpoint is flown (EXTENDED_SYS_STATE TAKEOFF)."""
        return self.work == TAKEOFF and not self.finished
