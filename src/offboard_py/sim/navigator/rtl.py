"""AUTO.RTL, PX4's direct return (navigator/rtl.cpp, rtl_direct.cpp): climb to the return altitude (sim.rtl),
return home at MPC_XY_CRUISE, descend to RTL_DESCEND_ALT, land."""

import math

from offboard_py.sim.flyer import land_setpoint, land_speed
from offboard_py.sim.navigator.navigator_mode import NavigatorMode
from offboard_py.sim.rtl import rtl_return_down


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
