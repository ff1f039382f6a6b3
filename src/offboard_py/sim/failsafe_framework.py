"""PX4's failsafe framework (PX4 main 02e73e3b6f, src/modules/commander/failsafe/framework.cpp, FailsafeBase):
the actions and their options, the state machine that turns the failed conditions a table reports into the
selected action, its delay, the pilot's takeover and what the pilot is told. The table itself is
sim.failsafe's (failsafe.cpp).

Each update the commander hands over its condition flags (`Flags`, PX4's failsafe_flags_s) and the mode the
user chose; the table turns each failed condition into an action with options (`Options`: what clears it,
whether the pilot may take over, its cause) through `_check`; the worst active action is selected
(getSelectedAction), falling back along PX4's chain when its mode cannot run (PosCtrl -> AltCtrl ->
Stabilized -> Hold -> RTL -> Land -> Descend -> Terminate). An action that allows takeover "Auto" is delayed
by COM_FAIL_ACT_T in Hold first: "Failsafe activated: entering Hold for N seconds", then "Failsafe activated"
as the action starts (notifyUser). A mode change by the user during a failsafe takes over where the action
allows it. `update` returns the user's mode (a failsafe can change it) and `selected` is the action; the mode
flying is `mode_from_action(selected, user_mode)`. Texts go to `notices` as (MAV_SEVERITY, text, on_link):
PX4 says most of them only as events; the `mavlink_log_critical` lines are STATUSTEXT. Pure: time is passed in.
"""

import enum

from offboard_py.dialect import mavlink
from offboard_py.sim.battery_simulator import WARNING_NONE


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


class Selected:
    """FailsafeBase::SelectedActionState."""

    def __init__(self, user_mode):
        self.action = Action.NONE
        self.delayed_action = Action.NONE
        self.cause = Cause.GENERIC
        self.user_mode = user_mode
        self.user_takeover = False


class FailsafeBase:
    """FailsafeBase's state machine; a subclass gives the table (_check_state_and_mode, _check_mode_fallback)."""

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
                                 'Failsafe activated: entering Hold for %d seconds\t' % delay_s, True))
            return
        if action == Action.WARN:
            self._event(*_WARNINGS.get(cause, (mavlink.MAV_SEVERITY_WARNING,
                                               'Failsafe warning: %s' % _cause_text(cause))))
            return
        self._event(mavlink.MAV_SEVERITY_CRITICAL, '%s: switching to %s' % (_cause_text(cause), _action_text(action)))
        self.notices.append((mavlink.MAV_SEVERITY_CRITICAL, 'Failsafe activated\t', True))

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

    # -- what the table (failsafe.Failsafe) gives --------------------------------------------------

    def _check_state_and_mode(self, armed, user_mode, flags):
        raise NotImplementedError

    def _check_mode_fallback(self, flags, user_mode):
        raise NotImplementedError

    def _modify_user_mode(self, previous_action, action, user_mode):
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
