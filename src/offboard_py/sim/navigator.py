"""Navigator of the simulated PX4: the setpoints of the AUTO modes, as PX4's navigator makes them.

- AUTO.TAKEOFF: climb above the takeoff point to MIS_TAKEOFF_ALT (or the commanded
  altitude) at MPC_TKO_SPEED, then report `TakeoffComplete` (the commander loiters).
- AUTO.LOITER, and any mode without a setpoint of its own: hold where the mode began.
- AUTO.RTL: climb to RTL_RETURN_ALT, return home at MPC_XY_CRUISE, land; next to home
  (RTL_MIN_DIST) it lands at once.
- AUTO.LAND: descend where the mode began, MPC_Z_VEL_MAX_DN high up and MPC_LAND_SPEED
  below MPC_LAND_ALT2.
- AUTO.MISSION: fly the mission items (`MissionRunner`), reporting reached items.
Pure: the vehicle model and the time are passed in; what must be said goes to `events`.
It neither decides modes (the commander does) nor flies (the vehicle model does).
"""

import math

from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import vehicle as vm

TAKEOFF_REACHED_M = 0.3
HOME_REACHED_M = 1.0      # RTL and mission landings: horizontal distance that counts as "there"
CLIMB_REACHED_M = 0.5     # RTL: within this of the return altitude the return begins

NAV_COMMANDS = frozenset((mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME,
                          mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LAND,
                          mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH))
ABSOLUTE_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT))


def _dist_xy(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1])


def land_setpoint(params, xy, vehicle):
    """Descend over xy at PX4's landing speeds: MPC_Z_VEL_MAX_DN high up, MPC_LAND_SPEED below ALT2."""
    height = vehicle.height()
    fast, slow = params['MPC_Z_VEL_MAX_DN'], params['MPC_LAND_SPEED']
    alt1, alt2 = params['MPC_LAND_ALT1'], params['MPC_LAND_ALT2']
    if height >= alt1:
        speed = fast
    elif height <= alt2 or alt1 <= alt2:
        speed = slow
    else:
        speed = slow + (fast - slow) * (height - alt2) / (alt1 - alt2)
    return vm.setpoint(position=(xy[0], xy[1], vm.NAN), velocity=(vm.NAN, vm.NAN, speed), yaw=vehicle.yaw)


class MissionRunner:
    """Flies mission items: NAV_TAKEOFF, NAV_WAYPOINT (acceptance radius, hold time), NAV_LOITER_TIME,
    NAV_LOITER_UNLIM, NAV_LAND and NAV_RETURN_TO_LAUNCH; other items (DO_*) are passed over."""

    def __init__(self, params, frame):
        self.params, self.frame = params, frame
        self.items = []
        self.seq = 0
        self.reached = []        # seq numbers reached since the last take_reached()
        self.finished = False
        self._arrived_s = None   # when the current item's position was reached
        self._hold_point = None
        self._takeoff_xy = None

    def load(self, items, seq=0):
        self.items, self.seq, self.finished = list(items), seq, False
        self._arrived_s = self._hold_point = self._takeoff_xy = None

    def set_current(self, seq):
        if 0 <= seq < len(self.items):
            self.seq, self.finished, self._arrived_s = seq, False, None
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
            down = -it.z
        return (north, east, down)

    def _advance(self):
        self.reached.append(self.seq)
        self._arrived_s = None
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
            return vm.hold(self._hold_point, vehicle.yaw)
        self._hold_point = None
        it = self.items[self.seq]
        pos = vehicle.position
        if it.command == mavlink.MAV_CMD_NAV_TAKEOFF:
            target = self._target(it, vehicle)
            if self._takeoff_xy is None:
                self._takeoff_xy = (pos[0], pos[1])
            north, east = self._takeoff_xy
            down = target[2] if target[2] < -0.5 else -p['MIS_TAKEOFF_ALT']
            if abs(pos[2] - down) <= p['NAV_MC_ALT_RAD'] * 0.5:
                self._takeoff_xy = None
                self._advance()
            return vm.setpoint(position=(north, east, down), yaw=vehicle.yaw, z_up_max=p['MPC_TKO_SPEED'])
        if it.command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._fly_then_land((0.0, 0.0), vehicle)
        target = self._target(it, vehicle)
        if it.command == mavlink.MAV_CMD_NAV_LAND:
            return self._fly_then_land(target, vehicle)
        radius = it.param2 if it.command == mavlink.MAV_CMD_NAV_WAYPOINT and it.param2 > 0 else p['NAV_ACC_RAD']
        if self._arrived_s is None and (_dist_xy(pos, target) <= radius
                                        and abs(pos[2] - target[2]) <= p['NAV_MC_ALT_RAD']):
            self._arrived_s = now_s
        if self._arrived_s is not None and it.command in (mavlink.MAV_CMD_NAV_WAYPOINT,
                                                          mavlink.MAV_CMD_NAV_LOITER_TIME):
            if now_s - self._arrived_s >= max(it.param1, 0.0):
                self._advance()
        return vm.setpoint(position=target, yaw=vehicle.yaw, xy_speed_max=p['MPC_XY_CRUISE'])

    def _fly_then_land(self, xy, vehicle):
        pos = vehicle.position
        if _dist_xy(pos, xy) > HOME_REACHED_M:
            return vm.setpoint(position=(xy[0], xy[1], pos[2]), yaw=vehicle.yaw, xy_speed_max=self.params['MPC_XY_CRUISE'])
        if vehicle.landed:
            self._advance()
            self.finished = True
            return vm.hold((xy[0], xy[1], 0.0), vehicle.yaw)
        return land_setpoint(self.params, xy, vehicle)


class Navigator:
    """The setpoint of the AUTO modes (and the hold of modes without one) for the mode flying now."""

    def __init__(self, params, frame, vehicle):
        self.params, self.vehicle = params, vehicle
        self.mission = MissionRunner(params, frame)
        self.events = []
        self.hold_point = tuple(vehicle.position)
        self.hold_yaw = vehicle.yaw
        self.takeoff_target = None
        self.land_xy = None
        self.rtl_phase = None

    # -- what the commander decided ------------------------------------------------------------

    def on_mode(self, mode):
        """A new mode is flying: remember where it began."""
        v = self.vehicle
        self.hold_point = (v.position[0], v.position[1], min(v.position[2], 0.0))
        self.hold_yaw = v.yaw
        if mode == 'AUTO.LAND':
            self.land_xy = (v.position[0], v.position[1])
        elif mode == 'AUTO.RTL':
            near = math.hypot(v.position[0], v.position[1]) < self.params['RTL_MIN_DIST']
            self.rtl_phase = 'land' if near else 'climb'
        elif mode == 'AUTO.MISSION':
            self.mission.restart_if_finished()
            self.events.append(ev.MissionCurrent(self.mission.seq))
        if mode != 'AUTO.TAKEOFF':
            self.takeoff_target = None
        elif self.takeoff_target is None:
            self.takeoff_target = (v.position[0], v.position[1], -self.params['MIS_TAKEOFF_ALT'])

    def on_armed(self, mode):
        self.hold_point = tuple(self.vehicle.position)
        if mode == 'AUTO.MISSION':
            self.mission.restart_if_finished()

    def takeoff_height(self, altitude_amsl, home_alt):
        """NAV_TAKEOFF's altitude as a height above home, or MIS_TAKEOFF_ALT when it is NaN or too low."""
        if math.isfinite(altitude_amsl):
            wanted = altitude_amsl - home_alt
            if wanted > self.vehicle.height() + 0.5:
                return wanted
            self.events.append(ev.StatusText(mavlink.MAV_SEVERITY_WARNING,
                                             'Takeoff altitude below the vehicle, using MIS_TAKEOFF_ALT'))
        return self.params['MIS_TAKEOFF_ALT']

    def set_takeoff_height(self, height):
        v = self.vehicle
        self.takeoff_target = (v.position[0], v.position[1], -height)

    def load_mission(self, items, flying_it):
        self.mission.load(items)
        if flying_it:
            self.events.append(ev.MissionCurrent(0))

    def landing(self, mode):
        """Whether the vehicle is landing in `mode` (EXTENDED_SYS_STATE's LANDING)."""
        return mode == 'AUTO.LAND' or (mode == 'AUTO.RTL' and self.rtl_phase == 'land')

    # -- the setpoint ------------------------------------------------------------------------

    def setpoint(self, mode, armed, now_s):
        v, p = self.vehicle, self.params
        if mode == 'AUTO.TAKEOFF' and self.takeoff_target is not None:
            if armed and abs(v.position[2] - self.takeoff_target[2]) <= TAKEOFF_REACHED_M:
                self.events.append(ev.TakeoffComplete())
                return vm.hold((v.position[0], v.position[1], min(v.position[2], 0.0)), v.yaw)
            return vm.setpoint(position=self.takeoff_target, yaw=self.hold_yaw, z_up_max=p['MPC_TKO_SPEED'])
        if mode == 'AUTO.LAND':
            return land_setpoint(p, self.land_xy, v)
        if mode == 'AUTO.RTL':
            return self._rtl_setpoint()
        if mode == 'AUTO.MISSION' and armed:
            sp = self.mission.setpoint(v, now_s)
            for seq in self.mission.take_reached():
                self.events.append(ev.ItemReached(seq))
                if not self.mission.finished:
                    self.events.append(ev.MissionCurrent(self.mission.seq))
            return sp
        return vm.hold(self.hold_point, self.hold_yaw)

    def _rtl_setpoint(self):
        v, p = self.vehicle, self.params
        if self.rtl_phase == 'climb':
            height = max(p['RTL_RETURN_ALT'], v.height())
            if v.height() >= height - CLIMB_REACHED_M:
                self.rtl_phase = 'return'
            return vm.setpoint(position=(self.hold_point[0], self.hold_point[1], -height), yaw=v.yaw)
        if self.rtl_phase == 'return':
            if math.hypot(v.position[0], v.position[1]) < HOME_REACHED_M:
                self.rtl_phase = 'land'
            return vm.setpoint(position=(0.0, 0.0, v.position[2]), yaw=v.yaw, xy_speed_max=p['MPC_XY_CRUISE'])
        return land_setpoint(p, (0.0, 0.0), v)
