"""A ground station's joystick as PX4's commander sees it (PX4 main 02e73e3b6f): MANUAL_CONTROL is PX4 SITL's only
manual control (COM_RC_IN_MODE 1). PX4's ManualControl selector drops the input COM_RC_LOSS_T after its last sample,
looking at each sample and, without one, every LOOK_PERIOD_S (ManualControl::Run's ScheduleDelayed(200_ms),
ManualControlSelector): the loss shows on the first look at or after COM_RC_LOSS_T (0.6 s for PX4 SITL's 0.5).
Commander::manualControlCheck keeps from each sample whether the throttle is above the centre or low, which
Commander::arm's stick checks look at in a manual mode. Pure: time is passed in."""

import math

from offboard_py import px4_modes
from offboard_py.dialect import mavlink

LOOK_PERIOD_S = 0.2  # ManualControl::Run without a new sample
# Commander::manualControlCheck: the throttle stick (-1..1) above the centre, and low
THROTTLE_ABOVE_CENTER, THROTTLE_LOW = 0.2, -0.8
# The manual modes whose vehicle_control_mode controls the climb rate (commander/ModeUtil/control_mode.cpp)
CLIMB_RATE_CONTROLLED = frozenset(('ALTCTL', 'POSCTL', 'POSCTL.SLOW', 'ALTITUDE_CRUISE'))


class ManualControlInput:
    def __init__(self, params):
        self.params = params
        self.last_s = None    # the last MANUAL_CONTROL
        self.sticks = None    # its sticks (sim.manual_control.ManualControlSetpoint), once one came with them
        self.throttle_above_center = self.throttle_low = False  # Commander's _is_throttle_above_center, _low

    def on_sample(self, now_s, sticks=None):
        self.last_s = now_s
        if sticks is not None:
            self.sticks = sticks
            self.throttle_above_center = sticks.throttle > THROTTLE_ABOVE_CENTER
            self.throttle_low = sticks.throttle < THROTTLE_LOW

    def signal(self, now_s):
        """The input is still taken (not yet counted lost)."""
        if self.last_s is None:
            return False
        looks = math.ceil(self.params['COM_RC_LOSS_T'] / LOOK_PERIOD_S - 1e-9)
        return now_s - self.last_s < looks * LOOK_PERIOD_S - 1e-9

    def arming_refusal(self, nav_mode, signal_lost):
        """Commander::arm's stick checks, before all others, in a manual mode while manual control is there: where
        the climb rate is controlled (ALTCTL, POSCTL) the throttle must not be above the centre, elsewhere (MANUAL,
        STABILIZED, ACRO) it must be low. TRANSITION_DENIED: TEMPORARILY_REJECTED for the command. Only sticks a
        MANUAL_CONTROL brought count (the simulated RC receiver has none). (reason or None, MAV_RESULT)."""
        if self.sticks is None or nav_mode not in px4_modes.MANUAL_MODES or signal_lost:
            return None, mavlink.MAV_RESULT_ACCEPTED
        if nav_mode in CLIMB_RATE_CONTROLLED:
            if self.throttle_above_center:
                return 'throttle above center\t', mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        elif not self.throttle_low:
            return 'high throttle\t', mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        return None, mavlink.MAV_RESULT_ACCEPTED
