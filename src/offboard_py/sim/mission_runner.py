"""The mission's items flown, as PX4's navigator Mission does: NAV_TAKEOFF, NAV_WAYPOINT (acceptance
radius, hold time, passed at PX4's corner speed), NAV_LOITER_TIME, NAV_LOITER_UNLIM, NAV_LAND and
NAV_RETURN_TO_LAUNCH; the reached items reported. Pure: the vehicle model and the time are passed in.
"""

from offboard_py.dialect import mavlink
from offboard_py.sim import vehicle as vm
from offboard_py.sim.flyer import Flyer, dist_xy, land_setpoint
from offboard_py.sim.trajectory import corner_speed

NAV_COMMANDS = frozenset((mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME,
                          mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LAND,
                          mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH))
ABSOLUTE_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT))


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
        if self._arrived_s is None and (dist_xy(pos, target) <= radius
                                        and abs(pos[2] - target[2]) <= p['NAV_MC_ALT_RAD']):
            self._arrived_s = now_s
        if self._arrived_s is not None and hold_s is not None and now_s - self._arrived_s >= hold_s:
            self._advance(vehicle)
        return self.flyer.fly_to(vehicle, target, now_s, speed_at_target=corner)

    def _fly_then_land(self, target, vehicle, now_s):
        pos = vehicle.position
        if dist_xy(pos, target) > self.params['NAV_ACC_RAD'] and not vehicle.landed:
            return self.flyer.fly_to(vehicle, (target[0], target[1], pos[2] if self.flyer.trajectory is None
                                               else self.flyer.trajectory.position[2]), now_s)
        if vehicle.landed:
            self._advance()
            self.finished = self.landed_at_end = True
            return self.flyer.direct(vm.hold((target[0], target[1], vehicle.ground_z), vehicle.yaw))
        return self.flyer.direct(land_setpoint(self.params, target, vehicle))
