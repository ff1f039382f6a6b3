"""AUTO.LOITER, as PX4's navigator/loiter.cpp: hold where the mode began, or fly to a reposition target."""

from offboard_py.sim.navigator.navigator_mode import NavigatorMode


class Loiter(NavigatorMode):
    """AUTO.LOITER, and any mode without a setpoint of its own: hold where the mode began (after a
    takeoff, at the takeoff altitude), or fly to a reposition target (MAV_CMD_DO_REPOSITION) and
    hold there, as PX4's loiter.cpp does."""

    def __init__(self, nav):
        super().__init__(nav)
        self.after_takeoff = None  # where to hold once a takeoff completes
        self.reposition = None     # (target local NED, xy speed or None for MPC_XY_CRUISE, yaw or NaN)

    def on_activation(self):
        if self.after_takeoff is not None:
            self.nav.hold_point = self.after_takeoff

    def on_inactivation(self):
        self.reposition = None

    def setpoint(self, armed, now_s):
        if self.reposition is None or not armed:
            return super().setpoint(armed, now_s)
        nav = self.nav
        target, speed, yaw = self.reposition
        sp = nav.flyer.fly_to(nav.vehicle, target, now_s, xy_speed=speed)
        return sp if yaw != yaw else sp._replace(yaw=yaw)
