"""AUTO.LAND (and AUTO.PRECLAND without a target), as PX4's navigator/land.cpp: descend where the mode began
at PX4's landing speeds (sim.flyer.land_speed)."""

from offboard_py.sim.flyer import land_setpoint
from offboard_py.sim.navigator.navigator_mode import NavigatorMode


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
