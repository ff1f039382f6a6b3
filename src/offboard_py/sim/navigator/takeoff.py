"""AUTO.TAKEOFF, as PX4's navigator/takeoff.cpp: climb above the takeoff point to MIS_TAKEOFF_ALT (or the
commanded altitude) at MPC_TKO_SPEED; within NAV_MC_ALT_RAD of it report `TakeoffComplete`."""

from offboard_py.sim import events as ev
from offboard_py.sim import vehicle as vm
from offboard_py.sim.navigator.navigator_mode import NavigatorMode


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

    def taking_off(self):
        return True
