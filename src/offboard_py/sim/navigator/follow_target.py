"""AUTO.FOLLOW_TARGET, as PX4's follow-me (navigator/follow_target.cpp; here sim.follow_target): follow the
target of the FOLLOW_TARGET messages."""

from offboard_py.sim.navigator.navigator_mode import NavigatorMode


class FollowTargetMode(NavigatorMode):
    """AUTO.FOLLOW_TARGET: PX4's follow-me (sim.follow_target), on the target the FOLLOW_TARGET messages give."""

    def on_activation(self):
        self.nav.follow.reset()

    def setpoint(self, armed, now_s):
        nav = self.nav
        return nav.follow.setpoint(nav.vehicle, nav.home, nav.params, now_s)
