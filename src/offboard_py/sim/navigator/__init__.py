"""Navigator of the simulated PX4: the setpoints of the AUTO modes, as PX4's navigator makes them.

- AUTO.TAKEOFF: climb above the takeoff point to MIS_TAKEOFF_ALT (or the commanded
  altitude) at MPC_TKO_SPEED; within NAV_MC_ALT_RAD of it report `TakeoffComplete` (the
  commander loiters, at the takeoff altitude).
- AUTO.LOITER, and any mode without a setpoint of its own: hold where the mode began.
- AUTO.RTL, PX4's direct return: climb to the return altitude (RTL_RETURN_ALT above home,
  lower inside the RTL_CONE_ANG cone within RTL_MIN_DIST, never lower than now), return home at
  MPC_XY_CRUISE, descend to RTL_DESCEND_ALT, land.
- AUTO.LAND: descend where the mode began at PX4's landing speeds (sim.flyer.land_speed).
- AUTO.MISSION: fly the mission items (sim.mission_runner), reporting reached items; waypoints
  are reached within NAV_ACC_RAD / NAV_MC_ALT_RAD and passed at PX4's corner speed.
- AUTO.FOLLOW_TARGET: follow the target of the FOLLOW_TARGET messages (sim.follow_target).
Flights between points follow PX4's jerk-limited trajectory (sim.flyer, sim.trajectory).
Altitudes are relative to `home` (local NED), which the flight stack sets at arming.
Pure: the vehicle model and the time are passed in; what must be said goes to `events`.
It neither decides modes (the commander does) nor flies (the vehicle model does).

One module per mode, as PX4's src/modules/navigator: navigator_mode (the base), loiter, takeoff,
land, rtl, mission, follow_target; the Navigator is here.
"""

import math

from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import vehicle as vm
from offboard_py.sim.flyer import Flyer
from offboard_py.sim.follow_target import FollowTarget
from offboard_py.sim.mission_runner import MissionRunner
from offboard_py.sim.navigator.follow_target import FollowTargetMode
from offboard_py.sim.navigator.land import Land
from offboard_py.sim.navigator.loiter import Loiter
from offboard_py.sim.navigator.mission import MissionMode
from offboard_py.sim.navigator.navigator_mode import NavigatorMode
from offboard_py.sim.navigator.rtl import Rtl
from offboard_py.sim.navigator.takeoff import Takeoff

__all__ = ['FollowTargetMode', 'GIMBAL_DELAY_S', 'Land', 'Loiter', 'MissionMode', 'Navigator', 'NavigatorMode', 'Rtl',
           'Takeoff']


# The gimbal commands of a return left 0.16-0.4 s after its setpoint took over (reference/conversations:
# POSITION_TARGET_LOCAL_NED changed at 56.36-56.46 s and 56.76-56.96 s, COMMAND_LONG 1001 at 56.62 and 57.17 s),
# 1.29-1.37 s after the last setpoint
GIMBAL_DELAY_S = 0.25


class Navigator:
    """The setpoint of the AUTO modes (and the hold of modes without one) for the mode flying now:
    one NavigatorMode per AUTO mode, the hold for the others."""

    def __init__(self, params, origin, vehicle):
        self.params, self.vehicle = params, vehicle
        self.mission = MissionRunner(params, origin)
        self.flyer = Flyer(params)
        self.events = []
        self.home = (0.0, 0.0, 0.0)
        self.hold_point = tuple(vehicle.position)
        self.hold_yaw = vehicle.yaw
        self.loiter = Loiter(self)
        self.takeoff = Takeoff(self)
        self.rtl = Rtl(self)
        land = Land(self)
        # AUTO.PRECLAND with no landing target in sight lands where it is, as PX4's precland falls back
        self.follow = FollowTarget()
        self.modes = {'AUTO.LOITER': self.loiter, 'AUTO.TAKEOFF': self.takeoff, 'AUTO.LAND': land,
                      'AUTO.PRECLAND': land, 'AUTO.RTL': self.rtl, 'AUTO.MISSION': MissionMode(self),
                      'AUTO.FOLLOW_TARGET': FollowTargetMode(self)}
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
        if mode in ('AUTO.LAND', 'AUTO.PRECLAND', 'AUTO.RTL'):
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
        home_amsl = self.mission.origin.alt0 - self.home[2]
        self.events.append(ev.VehicleCommand(0, (0.0, p['NAV_ACC_RAD'], p['NAV_LOITER_RAD'], vm.NAN, 0.0, 0.0,
                                                 home_amsl), True))

    def on_armed(self, mode):
        self.hold_point = tuple(self.vehicle.position)
        if mode == 'AUTO.MISSION':
            self.mission.restart_if_finished()

    def set_reposition(self, target, speed, yaw, armed):
        """MAV_CMD_DO_REPOSITION's target (local NED) for AUTO.LOITER to fly at `speed` (m/s, None:
        MPC_XY_CRUISE) facing `yaw` (NaN: as it is). PX4's navigator takes it only while armed."""
        if armed:
            self.loiter.reposition = (tuple(target), speed, yaw)
            self.flyer.direct(None)  # a new trajectory from where the vehicle is

    def takeoff_height(self, altitude_amsl, home_alt):
        """NAV_TAKEOFF's altitude as a height above home (`home_alt` AMSL), as navigator/takeoff.cpp's
        set_takeoff_position takes it: NaN is MIS_TAKEOFF_ALT above the vehicle ("Using default takeoff
        altitude"); an altitude below the vehicle is where the vehicle is ("Already higher than takeoff
        altitude": PX4 does not descend, and on the ground it stays there)."""
        here = self.home[2] - self.vehicle.estimate[0][2]  # the estimate, as PX4 reads its global position
        if not math.isfinite(altitude_amsl):
            default = self.params['MIS_TAKEOFF_ALT']
            self.events.append(ev.StatusText(mavlink.MAV_SEVERITY_INFO, 'Using default takeoff altitude: %.1f m\t'
                                             % default))
            return here + default
        wanted = altitude_amsl - home_alt
        if wanted < here:
            self.events.append(ev.StatusText(mavlink.MAV_SEVERITY_CRITICAL, 'Already higher than takeoff altitude\t'))
            return here
        return wanted

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

    def taking_off(self, mode):
        """Whether the vehicle is taking off in `mode` (EXTENDED_SYS_STATE's TAKEOFF)."""
        return self.modes.get(mode, self.hold).taking_off()

    # -- the setpoint ------------------------------------------------------------------------

    def setpoint(self, mode, armed, now_s):
        return self.modes.get(mode, self.hold).setpoint(armed, now_s)
