"""PX4's failsafe framework for the simulated PX4's commander: which action a failed condition calls for,
when it starts, when the pilot may take over, and what the pilot is told (PX4 main 02e73e3b6f,
src/modules/commander/failsafe/: framework.cpp is `Failsafe`'s state machine, failsafe.cpp its table).

Each update the commander hands over its condition flags (`Flags`, PX4's failsafe_flags_s) and the mode the
user chose; the table (`_check_state_and_mode`, Failsafe::checkStateAndMode) turns each failed condition
into an action with options (what clears it, whether the pilot may take over, its cause); the worst active
action is selected (getSelectedAction), falling back along PX4's chain when its mode cannot run
(PosCtrl -> AltCtrl -> Stabilized -> Hold -> RTL -> Land -> Descend -> Terminate). An action that allows
takeover "Auto" (battery, data link, RC, geofence RTL/Land) is delayed by COM_FAIL_ACT_T in Hold first:
"Failsafe activated: entering Hold for N seconds", then "Failsafe activated" as the action starts
(notifyUser). A mode change by the user during a failsafe takes over where the action allows it.
`update` returns the user's mode (a failsafe can change it) and `selected` is the action; the mode flying
is `mode_from_action(selected, user_mode)`. Texts go to `notices` as (MAV_SEVERITY, text, on_link):
PX4 says most of them only as events; the `mavlink_log_critical` lines are STATUSTEXT.

Modes are mavros's strings (px4_modes). What PX4 has and this does not: failsafe deferring (mode
executors), VTOL, wind, flight time, position accuracy, navigator and failure-detector conditions,
stick takeover (the simulated RC's sticks stay centred). Pure: time is passed in.
"""

import enum

from offboard_py.dialect import mavlink
from offboard_py.sim.battery_simulator import (WARNING_CRITICAL, WARNING_EMERGENCY, WARNING_LOW, WARNING_NONE)


class Action(enum.IntEnum):
    """FailsafeBase::Action: further down takes precedence."""
    NONE = 0
    WARN = 1
    FALLBACK_POSCTL = 2
    FALLBACK_ALTCTL = 3
    FALLBACK_STAB = 4
    HOLD = 5
    RTL = 6
    LAND = 7
    DESCEND = 8
    DISARM = 9
    TERMINATE = 10


class Clear(enum.IntEnum):
    """FailsafeBase::ClearCondition."""
    WHEN_CONDITION_CLEARS = 0
    ON_MODE_CHANGE_OR_DISARM = 1
    ON_DISARM = 2
    NEVER = 3


class Cause(enum.IntEnum):
    GENERIC = 0
    MANUAL_CONTROL_LOSS = 1
    GCS_CONNECTION_LOSS = 2
    BATTERY_LOW = 3
    BATTERY_CRITICAL = 4
    BATTERY_EMERGENCY = 5


class Takeover(enum.IntEnum):
    """FailsafeBase::UserTakeoverAllowed, least restrictive first."""
    ALWAYS = 0
    MODE_SWITCH_ONLY = 1
    AUTO = 2   # with COM_FAIL_ACT_T > 0.1: Hold for that long first, then the action (takeover allowed)
    NEVER = 3


# COM_RCL_EXCEPT / COM_DLL_EXCEPT bits (failsafe.h LinkLossExceptionBits)
EXCEPT_MISSION, EXCEPT_AUTO_MODES, EXCEPT_OFFBOARD = 1, 2, 4
EXCEPT_ALTITUDE_CRUISE = 16
AUTO_MODES = frozenset(('AUTO.LOITER', 'AUTO.TAKEOFF', 'AUTO.VTOL_TAKEOFF', 'AUTO.LAND', 'AUTO.RTL', 'DESCEND',
                        'AUTO.FOLLOW_TARGET', 'AUTO.PRECLAND', 'POSCTL.ORBIT'))
RC_IN_MODE_DISABLED = 4        # COM_RC_IN_MODE: DisableManualControl
FAIL_ACT_T_MIN_S = 0.1         # a shorter COM_FAIL_ACT_T means no Hold first
# The mode a multicopter needs valid, per mode (ModeUtil/mode_requirements.cpp; attitude and rates are
# always valid here, manual control is checked apart, as modeCanRun does)
REQUIREMENTS = {
    'ALTCTL': ('local_altitude_invalid',),
    'ALTITUDE_CRUISE': ('local_altitude_invalid',),
    'POSCTL': ('local_altitude_invalid', 'local_position_invalid_relaxed'),
    'POSCTL.SLOW': ('local_altitude_invalid', 'local_position_invalid_relaxed'),
    'AUTO.MISSION': ('global_position_invalid', 'local_position_invalid', 'local_altitude_invalid',
                     'auto_mission_missing'),
    'AUTO.LOITER': ('global_position_invalid', 'local_position_invalid', 'local_altitude_invalid'),
    'AUTO.RTL': ('global_position_invalid', 'local_position_invalid', 'local_altitude_invalid',
                 'home_position_invalid'),
    'AUTO.TAKEOFF': ('local_altitude_invalid', 'local_position_invalid'),
    'AUTO.LAND': ('local_altitude_invalid', 'local_position_invalid_relaxed'),
    'AUTO.FOLLOW_TARGET': ('local_position_invalid', 'local_altitude_invalid'),
    'AUTO.PRECLAND': ('local_position_invalid', 'local_altitude_invalid'),
    'POSCTL.ORBIT': ('local_position_invalid', 'local_altitude_invalid'),
    'OFFBOARD': ('offboard_control_signal_lost',),
    'DESCEND': (),
}
# FailsafeBase::modeFromAction; Descend is shown as AUTO.LAND on MAVLink (px4_custom_mode.h)
MODE_OF_ACTION = {Action.FALLBACK_POSCTL: 'POSCTL', Action.FALLBACK_ALTCTL: 'ALTCTL',
                  Action.FALLBACK_STAB: 'STABILIZED', Action.HOLD: 'AUTO.LOITER', Action.RTL: 'AUTO.RTL',
                  Action.LAND: 'AUTO.LAND', Action.DESCEND: 'DESCEND'}


class Flags:
    """The conditions the commander reports (failsafe_flags_s), all good by default."""

    def __init__(self, **values):
        self.manual_control_signal_lost = False
        self.gcs_connection_lost = False
        self.geofence_breached = False
        self.battery_warning = WARNING_NONE
        self.offboard_control_signal_lost = False
        self.local_position_invalid = False
        self.local_position_invalid_relaxed = False
        self.global_position_invalid = False
        self.local_altitude_invalid = False
        self.home_position_invalid = False
        self.auto_mission_missing = False
        for name, value in values.items():
            if not hasattr(self, name):
                raise AttributeError('no failsafe flag %r' % name)
            setattr(self, name, value)

    def copy(self):
        flags = Flags()
        flags.__dict__.update(self.__dict__)
        return flags


def mode_can_run(flags, mode):
    """FailsafeBase::modeCanRun: every condition `mode` requires holds."""
    return not any(getattr(flags, flag) for flag in REQUIREMENTS.get(mode, ()))


def mode_from_action(action, user_mode):
    """The mode flying for an action (FailsafeBase::modeFromAction): the user's for None, Warn,
    Disarm and Terminate."""
    return MODE_OF_ACTION.get(action, user_mode)


class Options:
    """FailsafeBase::ActionOptions: an action and how it behaves."""

    def __init__(self, action, clear=Clear.WHEN_CONDITION_CLEARS, cause=Cause.GENERIC, takeover=Takeover.AUTO):
        self.action, self.clear, self.cause, self.takeover = action, clear, cause, takeover
        self.caller = None
        self.state_failure = False
        self.activated = False


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


class Selected:
    """FailsafeBase::SelectedActionState."""

    def __init__(self, user_mode):
        self.action = Action.NONE
        self.delayed_action = Action.NONE
        self.cause = Cause.GENERIC
        self.user_mode = user_mode
        self.user_takeover = False


class Failsafe:
    """PX4's Failsafe (framework.cpp and failsafe.cpp) over the conditions this simulator models."""

    def __init__(self, params):
        self.params = params
        self.actions = []
        self.last_update_s = None
        self.last_armed = False
        self.last_user_mode = None
        self.last_flags = Flags()
        self.selected = Action.NONE
        self.user_takeover_active = False
        self.notification_required = False
        self.current_start_delay_s = params['COM_FAIL_ACT_T']
        self.current_delay_s = 0.0
        self.was_armed = False
        self.manual_control_lost_at_arming = False
        self.battery_warning_at_arming = WARNING_NONE
        self.last_state = {}       # caller -> failed at the last update (the _last_state_* of failsafe.h)
        self.notices = []          # (MAV_SEVERITY, text, on_link) for the commander to say
        self.on_notify_user = None  # called before a notification (Commander::onFailsafeNotifyUser)

    def in_failsafe(self):
        return self.selected not in (Action.NONE, Action.WARN)

    # -- FailsafeBase::update ------------------------------------------------------------------

    def update(self, now_s, armed, user_mode, user_mode_updated, flags):
        """One update; returns the user's mode (a takeover or an action can change it)."""
        if self.last_update_s is None:
            self.last_update_s = now_s
        if armed != self.last_armed:
            self._remove_actions(Clear.ON_DISARM)
            self._remove_actions(Clear.ON_MODE_CHANGE_OR_DISARM)
            self.user_takeover_active = False
        user_mode_updated = user_mode_updated or self.last_user_mode != user_mode
        if user_mode_updated or self.user_takeover_active:
            self._remove_actions(Clear.ON_MODE_CHANGE_OR_DISARM)
        dt = max(0.0, now_s - self.last_update_s)
        self.current_delay_s = max(0.0, self.current_delay_s - dt)
        self._check_state_and_mode(armed, user_mode, flags)
        self._remove_non_activated_actions()
        self._clear_delay_if_needed(flags)
        selected = self._select_action(armed, user_mode, flags, user_mode_updated)
        self._update_start_delay(dt, selected.delayed_action != Action.NONE)
        if selected.action > self.selected or (selected.action != Action.NONE and self.notification_required):
            self._notify_user(selected.action, selected.delayed_action, selected.cause)
        self.notification_required = False
        self.last_user_mode = self._modify_user_mode(self.selected, selected.action, selected.user_mode)
        self.user_takeover_active = selected.user_takeover
        self.selected = selected.action
        self.last_update_s = now_s
        self.last_flags = flags.copy()
        self.last_armed = armed
        return self.last_user_mode

    def _update_start_delay(self, dt, delay_active):
        """A delay that is running shortens the next one; without one it grows back at a quarter of
        the time, up to COM_FAIL_ACT_T (so a toggling condition still gets its action at some point)."""
        if delay_active:
            self.current_start_delay_s = max(0.0, self.current_start_delay_s - dt)
        else:
            self.current_start_delay_s = min(self.current_start_delay_s + dt / 4.0, self.params['COM_FAIL_ACT_T'])

    def _remove_actions(self, clear):
        self.actions = [a for a in self.actions if a.state_failure or a.clear != clear]

    def _remove_action(self, action):
        """The condition of `action` holds again: gone if it clears with it, else only flagged."""
        if action.clear == Clear.WHEN_CONDITION_CLEARS:
            self.actions.remove(action)
        else:
            action.state_failure = False

    def _remove_non_activated_actions(self):
        for action in list(self.actions):
            if not action.activated:
                self._remove_action(action)
        for action in self.actions:
            action.activated = False

    def _notify_user(self, action, delayed_action, cause):
        """FailsafeBase::notifyUser: an event for each case, and the two STATUSTEXT lines."""
        if self.on_notify_user:
            self.on_notify_user()
        delay_s = int(self.current_delay_s + 0.5)
        if action == Action.HOLD and delayed_action != Action.NONE:
            self._event(mavlink.MAV_SEVERITY_CRITICAL, '%s: switching to %s in %d seconds'
                        % (_cause_text(cause), _action_text(delayed_action), delay_s))
            self.notices.append((mavlink.MAV_SEVERITY_CRITICAL,
                                 'Failsafe activated: entering Hold for %d seconds' % delay_s, True))
            return
        if action == Action.WARN:
            self._event(*_WARNINGS.get(cause, (mavlink.MAV_SEVERITY_WARNING,
                                               'Failsafe warning: %s' % _cause_text(cause))))
            return
        self._event(mavlink.MAV_SEVERITY_CRITICAL, '%s: switching to %s' % (_cause_text(cause), _action_text(action)))
        self.notices.append((mavlink.MAV_SEVERITY_CRITICAL, 'Failsafe activated', True))

    def _event(self, severity, text):
        self.notices.append((severity, text, False))

    # -- FailsafeBase::checkFailsafe -----------------------------------------------------------

    def _check(self, caller, failed, options, last_failed=None):
        """A condition's state this update: a failed one adds (or keeps) its action, one that holds
        again removes it as its clear condition says. `last_failed`: its state at the last update
        (default: at the last check of `caller`)."""
        if last_failed is None:
            last_failed = self.last_state.get(caller, False)
        self.last_state[caller] = failed
        found = next((a for a in self.actions if a.caller == caller), None)
        if failed:
            if found is not None:
                found.state_failure = found.activated = True
                found.action = options.action  # the action may change, the rest stays
                return
            options.caller, options.state_failure, options.activated = caller, True, True
            if options.takeover == Takeover.AUTO:
                if self.params['COM_FAIL_ACT_T'] > FAIL_ACT_T_MIN_S:
                    if options.action != Action.WARN and self.current_delay_s == 0:
                        self.current_delay_s = self.current_start_delay_s
                    options.takeover = Takeover.ALWAYS
                else:
                    options.takeover = Takeover.MODE_SWITCH_ONLY
            if options.action == Action.WARN:
                self.notification_required = True
            if options.action >= Action.HOLD:  # not a fallback: a takeover ends
                self.user_takeover_active = False
            self.actions.append(options)
        elif last_failed and found is not None:
            self._remove_action(found)

    def _check_flag(self, flags, name, options):
        """CHECK_FAILSAFE: a flag of failsafe_flags_s, its last state from the last update's flags."""
        self._check(name, bool(getattr(flags, name)), options, bool(getattr(self.last_flags, name)))

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

    def _clear_delay_if_needed(self, flags):
        if self.selected > Action.HOLD or not mode_can_run(flags, 'AUTO.LOITER') or self.user_takeover_active:
            self.current_delay_s = 0.0

    # -- FailsafeBase::getSelectedAction ---------------------------------------------------------

    def _select_action(self, armed, user_mode, flags, user_mode_updated):
        selected = Selected(user_mode)
        if user_mode == 'TERMINATION' or self.selected == Action.TERMINATE:  # never cleared
            selected.action = Action.TERMINATE
            return selected
        if not armed:
            return selected
        takeover = Takeover.ALWAYS
        for a in self.actions:
            takeover = max(takeover, a.takeover)
            if a.action > selected.action:
                selected.action, selected.cause = a.action, a.cause
        delayable = selected.action not in (Action.NONE, Action.WARN, Action.DISARM, Action.TERMINATE, Action.HOLD)
        if (self.current_delay_s > 0 and not self.user_takeover_active and takeover <= Takeover.MODE_SWITCH_ONLY
                and delayable):
            selected.delayed_action, selected.action = selected.action, Action.HOLD
            takeover = Takeover.MODE_SWITCH_ONLY
        # a takeover is a change of the user's mode while an action is on (the sticks never move here)
        want_takeover = user_mode_updated and self.selected > Action.WARN
        allowed = (takeover in (Takeover.ALWAYS, Takeover.MODE_SWITCH_ONLY)
                   and (self.user_takeover_active or want_takeover))
        if selected.action in (Action.HOLD, Action.RTL, Action.LAND, Action.DESCEND) and allowed:
            selected.action, selected.user_takeover = Action.WARN, True
            selected.delayed_action = Action.NONE
            fallback = self._check_mode_fallback(flags, mode_from_action(selected.action, selected.user_mode))
            selected.action = max(selected.action, fallback)
        self._fall_back_to_runnable(selected, flags)
        # already landing or returning: no return on top (a UX choice of PX4's)
        for mode, redundant in (('AUTO.LAND', (Action.RTL,)), ('AUTO.RTL', (Action.RTL,)),
                                ('AUTO.PRECLAND', (Action.RTL, Action.LAND))):
            if (selected.user_mode == mode and mode_can_run(flags, mode)
                    and (selected.action in redundant or selected.delayed_action in redundant)):
                selected.action, selected.delayed_action = Action.WARN, Action.NONE
        return selected

    def _fall_back_to_runnable(self, selected, flags):
        """The action's mode must be able to run, or the next down the chain is taken (getSelectedAction's
        switch): PosCtrl -> AltCtrl -> Stab -> Hold -> RTL -> Land -> Descend -> Terminate."""
        chain = (Action.FALLBACK_POSCTL, Action.FALLBACK_ALTCTL, Action.FALLBACK_STAB, Action.HOLD, Action.RTL,
                 Action.LAND, Action.DESCEND)
        if selected.action not in chain:
            return
        for action in chain[chain.index(selected.action):]:
            if mode_can_run(flags, mode_from_action(action, None)):
                selected.action = action
                return
            selected.cause = Cause.GENERIC
        selected.action = Action.TERMINATE


_ACTION_TEXT = {Action.FALLBACK_POSCTL: 'Position', Action.FALLBACK_ALTCTL: 'Altitude',
                Action.FALLBACK_STAB: 'Stabilized', Action.HOLD: 'Hold', Action.RTL: 'Return', Action.LAND: 'Land',
                Action.DESCEND: 'Descend', Action.DISARM: 'Disarm', Action.TERMINATE: 'Terminate'}
_CAUSE_TEXT = {Cause.GENERIC: 'Failsafe activated', Cause.MANUAL_CONTROL_LOSS: 'Manual control loss',
               Cause.GCS_CONNECTION_LOSS: 'GCS connection loss', Cause.BATTERY_LOW: 'Low battery level',
               Cause.BATTERY_CRITICAL: 'Critical battery level', Cause.BATTERY_EMERGENCY: 'Emergency battery level'}
# the warnings notifyUser sends for a battery cause (events only)
_WARNINGS = {Cause.BATTERY_LOW: (mavlink.MAV_SEVERITY_WARNING, 'Low battery level, return advised'),
             Cause.BATTERY_CRITICAL: (mavlink.MAV_SEVERITY_CRITICAL, 'Critical battery level, land now'),
             Cause.BATTERY_EMERGENCY: (mavlink.MAV_SEVERITY_EMERGENCY, 'Emergency battery level, land immediately')}


def _action_text(action):
    return _ACTION_TEXT.get(action, action.name)


def _cause_text(cause):
    return _CAUSE_TEXT[cause]
