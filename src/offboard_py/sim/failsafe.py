"""PX4's failsafe table for the simulated PX4's commander (PX4 main 02e73e3b6f,
src/modules/commander/failsafe/failsafe.cpp, Failsafe): which action each failed condition calls for, as the
parameters choose it (NAV_RCL_ACT, NAV_DLL_ACT, GF_ACTION, COM_LOW_BAT_ACT, COM_OBL_RC_ACT and their
exceptions), and the mode fallbacks. The state machine that selects, delays and announces the actions is
sim.failsafe_framework's (framework.cpp).

The actions that allow takeover "Auto" here: battery, data link, RC, geofence RTL/Land (Hold for
COM_FAIL_ACT_T first). Modes are mavros's strings (px4_modes). What PX4 has and this does not: failsafe
deferring (mode executors), VTOL, wind, flight time, position accuracy, navigator and failure-detector
conditions, stick takeover (the simulated RC's sticks stay centred). Pure: time is passed in.
"""

from offboard_py.sim.battery_simulator import WARNING_CRITICAL, WARNING_EMERGENCY, WARNING_LOW, WARNING_NONE
from offboard_py.sim.failsafe_framework import (REQUIREMENTS, Action, Cause, Clear, FailsafeBase, Options, Takeover,
                                                mode_can_run, mode_from_action)

# COM_RCL_EXCEPT / COM_DLL_EXCEPT bits (failsafe.h LinkLossExceptionBits)
EXCEPT_MISSION, EXCEPT_AUTO_MODES, EXCEPT_OFFBOARD = 1, 2, 4
EXCEPT_ALTITUDE_CRUISE = 16
AUTO_MODES = frozenset(('AUTO.LOITER', 'AUTO.TAKEOFF', 'AUTO.VTOL_TAKEOFF', 'AUTO.LAND', 'AUTO.RTL', 'DESCEND',
                        'AUTO.FOLLOW_TARGET', 'AUTO.PRECLAND', 'POSCTL.ORBIT'))
RC_IN_MODE_DISABLED = 4        # COM_RC_IN_MODE: DisableManualControl


def from_nav_dll_or_rcl_act(value, cause):
    """NAV_DLL_ACT / NAV_RCL_ACT (Failsafe::fromNavDllOrRclActParam): 1 Hold, 2 Return, 3 Land,
    5 Terminate, 6 Disarm; 0 and anything else nothing."""
    options = {1: Options(Action.HOLD, Clear.ON_MODE_CHANGE_OR_DISARM),
               2: Options(Action.RTL, Clear.ON_MODE_CHANGE_OR_DISARM),
               3: Options(Action.LAND, Clear.ON_MODE_CHANGE_OR_DISARM),
               5: Options(Action.TERMINATE, Clear.NEVER, takeover=Takeover.NEVER),
               6: Options(Action.DISARM, takeover=Takeover.NEVER)}.get(int(value), Options(Action.NONE))
    options.cause = cause
    return options


def from_gf_action(value):
    """GF_ACTION (Failsafe::fromGfActParam): 0 none, 1 warning, 2 Hold, 3 Return, 4 Terminate, 5 Land."""
    return {0: Options(Action.NONE),
            1: Options(Action.WARN),
            2: Options(Action.HOLD, Clear.ON_MODE_CHANGE_OR_DISARM, takeover=Takeover.MODE_SWITCH_ONLY),
            3: Options(Action.RTL, Clear.ON_MODE_CHANGE_OR_DISARM),
            4: Options(Action.TERMINATE, Clear.NEVER, takeover=Takeover.NEVER),
            5: Options(Action.LAND, Clear.ON_MODE_CHANGE_OR_DISARM)}.get(int(value), Options(Action.WARN))


def from_battery_warning(low_bat_act, warning):
    """COM_LOW_BAT_ACT for a battery warning (Failsafe::fromBatteryWarningActParam): 0 warning only,
    1 Return, 2 Land, 3 Return at critical and Land at emergency; a low battery is a warning only."""
    low_bat_act = int(low_bat_act)
    if warning == WARNING_LOW:
        return Options(Action.WARN, cause=Cause.BATTERY_LOW)
    if warning == WARNING_CRITICAL:
        action = {1: Action.RTL, 3: Action.RTL, 2: Action.LAND}.get(low_bat_act, Action.WARN)
        return Options(action, cause=Cause.BATTERY_CRITICAL)
    if warning == WARNING_EMERGENCY:
        action = {1: Action.RTL, 2: Action.LAND, 3: Action.LAND}.get(low_bat_act, Action.WARN)
        return Options(action, cause=Cause.BATTERY_EMERGENCY)
    return Options(Action.NONE)


def from_offboard_loss_act(value):
    """COM_OBL_RC_ACT (Failsafe::fromOffboardLossActParam): (action, the user's mode it stands for)."""
    return {1: (Action.FALLBACK_ALTCTL, 'ALTCTL'), 2: (Action.FALLBACK_STAB, 'STABILIZED'),
            3: (Action.RTL, 'AUTO.RTL'), 4: (Action.LAND, 'AUTO.LAND'), 5: (Action.HOLD, 'AUTO.LOITER'),
            6: (Action.TERMINATE, 'TERMINATION'), 7: (Action.DISARM, None)}.get(int(value),
                                                                              (Action.FALLBACK_POSCTL, 'POSCTL'))


def failsafe_ignored(user_mode, exception_mask):
    """Failsafe::isFailsafeIgnored: COM_RCL_EXCEPT / COM_DLL_EXCEPT exempt the user's mode."""
    exception_mask = int(exception_mask)
    if user_mode == 'AUTO.MISSION':
        return bool(exception_mask & EXCEPT_MISSION)
    if user_mode in AUTO_MODES:
        return bool(exception_mask & EXCEPT_AUTO_MODES)
    if user_mode == 'OFFBOARD':
        return bool(exception_mask & EXCEPT_OFFBOARD)
    if user_mode == 'ALTITUDE_CRUISE':
        return bool(exception_mask & EXCEPT_ALTITUDE_CRUISE)
    return False


class Failsafe(FailsafeBase):
    """PX4's Failsafe (failsafe.cpp) over the conditions this simulator models."""

    def __init__(self, params):
        super().__init__(params)
        self.was_armed = False
        self.manual_control_lost_at_arming = False
        self.battery_warning_at_arming = WARNING_NONE

    # -- Failsafe::checkStateAndMode -----------------------------------------------------------

    def _check_state_and_mode(self, armed, user_mode, flags):
        p = self.params
        self._update_arming_state(armed, flags)
        if not flags.manual_control_signal_lost:
            self.manual_control_lost_at_arming = False
        # RC lost counts only where RC was there at arming (or came since)
        rc_loss_ignored = failsafe_ignored(user_mode, p['COM_RCL_EXCEPT']) or self.manual_control_lost_at_arming
        if int(p['COM_RC_IN_MODE']) != RC_IN_MODE_DISABLED and not rc_loss_ignored:
            self._check_flag(flags, 'manual_control_signal_lost',
                             from_nav_dll_or_rcl_act(p['NAV_RCL_ACT'], Cause.MANUAL_CONTROL_LOSS))
        dll_ignored = (failsafe_ignored(user_mode, p['COM_DLL_EXCEPT'])
                       or user_mode in ('AUTO.LAND', 'AUTO.PRECLAND'))
        if int(p['NAV_DLL_ACT']) != 0 and not dll_ignored:
            self._check_flag(flags, 'gcs_connection_lost',
                             from_nav_dll_or_rcl_act(p['NAV_DLL_ACT'], Cause.GCS_CONNECTION_LOSS))
        self._check_flag(flags, 'geofence_breached', from_gf_action(p['GF_ACTION']))
        # a battery already low at arming (COM_ARM_BAT_MIN) only warns until it gets worse
        low_bat_act = p['COM_LOW_BAT_ACT'] if flags.battery_warning > self.battery_warning_at_arming else 0
        for warning, caller in ((WARNING_LOW, 'battery_warning_low'), (WARNING_CRITICAL, 'battery_warning_critical'),
                                (WARNING_EMERGENCY, 'battery_warning_emergency')):
            if flags.battery_warning == warning:
                self._check(caller, True, from_battery_warning(low_bat_act, warning))
        fallback = self._check_mode_fallback(flags, user_mode)
        self._check('mode_fallback', fallback != Action.NONE, Options(fallback, takeover=Takeover.ALWAYS))

    def _update_arming_state(self, armed, flags):
        if not self.was_armed and armed:
            self.manual_control_lost_at_arming = flags.manual_control_signal_lost
            self.battery_warning_at_arming = flags.battery_warning
        elif not armed:
            self.manual_control_lost_at_arming = flags.manual_control_signal_lost
        self.was_armed = armed

    def _check_mode_fallback(self, flags, user_mode):
        """Failsafe::checkModeFallback: the offboard signal lost (COM_OBL_RC_ACT, NAV_RCL_ACT without RC),
        then each mode that cannot run falls back: Position -> Altitude -> Stabilized, anything else RTL."""
        p = self.params
        action = Action.NONE
        if flags.offboard_control_signal_lost and 'offboard_control_signal_lost' in REQUIREMENTS.get(user_mode, ()):
            action, user_mode = from_offboard_loss_act(p['COM_OBL_RC_ACT'])
            if action == Action.DISARM:
                return action
            if action in (Action.FALLBACK_POSCTL, Action.FALLBACK_ALTCTL, Action.FALLBACK_STAB) \
                    and flags.manual_control_signal_lost:
                action = from_nav_dll_or_rcl_act(p['NAV_RCL_ACT'], Cause.GENERIC).action
        if user_mode in ('POSCTL', 'POSCTL.SLOW') and not mode_can_run(flags, user_mode):
            action, user_mode = Action.FALLBACK_ALTCTL, 'ALTCTL'
        if user_mode == 'ALTCTL' and not mode_can_run(flags, user_mode):
            action, user_mode = Action.FALLBACK_STAB, 'STABILIZED'
        if not mode_can_run(flags, user_mode):
            action = Action.RTL
        return action

    def _modify_user_mode(self, previous_action, action, user_mode):
        """Out of a failsafe back into an orbit: loiter instead (Failsafe::modifyUserIntendedMode)."""
        if previous_action > Action.WARN and mode_from_action(action, user_mode) == 'POSCTL.ORBIT':
            return 'AUTO.LOITER'
        return user_mode

