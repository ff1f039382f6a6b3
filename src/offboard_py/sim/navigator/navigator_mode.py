"""The base of the navigator's modes (sim.navigator), as PX4's navigator/navigator_mode.cpp: the hold of a
mode without a setpoint of its own."""

from offboard_py.sim import vehicle as vm


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

    def taking_off(self):
        """A TAKEOFF setpoint is flown (EXTENDED_SYS_STATE TAKEOFF, as PX4's stream derives it from
        the current position setpoint's type)."""
        return False
