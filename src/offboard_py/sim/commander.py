"""The commander of the simulated PX4: modes, arming, the offboard signal, failsafes, timers.

Rules, as current PX4 applies them (reference/px4-behaviour.md):
- Boots in AUTO.LOITER, disarmed; arming is refused for `ready_delay_s` while the
  estimator settles (EKF2 fusing GPS about 3.8 s after boot on PX4 SITL). What SYS_STATUS says of it
  goes through the health report (sim.health_checks): a zeroed report until FIRST_REPORT_S, then the
  sensors present without the GPS, then the GPS present with PREARM_CHECK at the next report.
- HEARTBEAT's system_status as PX4 main reports it (reference/px4-sitl-measured.md, "Turn 3
  recordings", section 6): UNINIT while a pre-arm check fails (before ready, with an injected
  failure, OFFBOARD selected without the offboard signal, a manual mode without RC, AUTO.MISSION
  without a mission), STANDBY disarmed otherwise (straight after a disarm too), ACTIVE armed,
  CRITICAL in a failsafe. `prearm_ok()` is the same verdict, for SYS_STATUS's PREARM_CHECK health bit.
- The logger (SDLOG_MODE 1: from boot until the first disarm, then from each arming to its
  disarm): `logging()` says whether it runs, for SYS_STATUS's MAV_SYS_STATUS_LOGGING present and
  enabled bits; sim.logger_status says when it starts and stops.
- Two modes are tracked, as PX4 does: the mode the user chose (`user_mode`, shown as
  CURRENT_MODE.intended_custom_mode) and the mode flying now (`nav_mode`), which differs
  during a failsafe. After a disarm the vehicle returns to the last mode the user chose
  that is not a landing or takeoff mode.
- While disarmed every mode PX4 has is accepted, OFFBOARD too (UserModeIntention::change). While
  armed, OFFBOARD needs the offboard signal, manual modes need RC, AUTO.MISSION needs a mission.
  DO_SET_MODE and SET_MODE name the mode as Commander::handle_command maps them (`set_mode_target`):
  AUTO.READY, AUTO.RTGS, AUTO.VTOL_TAKEOFF and the old RATTITUDE are refused; nothing leaves
  TERMINATION.
- The offboard signal: an accepted setpoint younger than COM_OF_LOSS_T.
- Failsafes are PX4's failsafe framework (sim.failsafe), fed each cycle with the conditions PX4's checks
  report (failsafe_flags_s): the offboard signal (lost in OFFBOARD: COM_OBL_RC_ACT, whose RC-based
  choices fall to NAV_RCL_ACT without RC), manual control lost (the simulated RC is always on; a ground
  station's MANUAL_CONTROL stopping for COM_RC_LOSS_T: NAV_RCL_ACT, only where it was there at arming), the
  ground station lost (NAV_DLL_ACT: no GCS HEARTBEAT for COM_DL_LOSS_T, Commander::dataLinkCheck), the
  geofence (GF_ACTION), the battery's warning (COM_LOW_BAT_ACT) and a position the estimator lost (the
  modes that need it fall back). The mode flying is the action's; the user's choice stays (CURRENT_MODE's
  intended mode) and a mode change by the user takes over where the action allows it. A mode fallback ends
  with its condition: offboard setpoints back, the vehicle flies OFFBOARD again by itself while that is
  still the user's mode (real PX4 SITL does: reference/px4-sitl-offboard-regain.json).
- What the checks say goes through PX4's report (sim.health_checks): "Low battery", "Emergency battery
  level", "Geofence: ...", the GCS one, at most every 2 s, with the SYS_STATUS health they clear.
- Arming: refused while not ready, with an injected failure, in OFFBOARD without the
  signal, in a manual mode without RC, in AUTO.MISSION without a mission, in AUTO.LAND
  or AUTO.RTL; DENIED while not landed. Disarming is TEMPORARILY_REJECTED unless the land
  detector says landed or maybe landed (PX4's Commander::disarm; an OFFBOARD takeoff loses
  maybe-landed as its thrust rises). PX4's force magic (21196) skips the checks, but for Commander::arm's stick
  checks, which a command from a link always meets: with a ground station's sticks (MANUAL_CONTROL) in a manual
  mode, "Arming denied: throttle above center" where the climb rate is controlled (ALTCTL, POSCTL) and "Arming
  denied: high throttle" elsewhere unless the throttle is low, TEMPORARILY_REJECTED (reference/
  px4-sitl-manual-control.json, "arming").
- COM_DISARM_PRFLT: armed this long with no takeoff -> disarm. COM_DISARM_LAND: landed
  this long after a flight -> disarm. A mission that ends with a landing disarms as soon as it
  is down (measured on PX4 SITL: 0.02-0.41 s after landed).

Rules only: it neither makes setpoints (the navigator does) nor flies (the vehicle model
does). Pure: time is passed in, what it knows of the vehicle is set by the flight stack
(`landed`, `has_mission`), and what must be said or done goes to `events` (sim.events).
"""


from offboard_py import px4_modes
from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import failsafe as fs
from offboard_py.sim import failsafe_framework as ff
from offboard_py.sim.battery_simulator import WARNING_EMERGENCY, WARNING_NONE
from offboard_py.sim.data_link import DataLink
from offboard_py.sim.health_checks import FIRST_REPORT_S, HealthReport, failing_checks
from offboard_py.sim.logger_status import LoggerStatus
from offboard_py.sim.manual_control_input import ManualControlInput
from offboard_py.sim.mode_util import (FLOWN_AS, NAV_STATE_NAMES, NOT_ARMABLE, REFUSED_MODES, TRANSIENT_MODES,
                                      set_mode_target)

# EKF2 fuses GPS and PX4 sets home again 3.79 and 3.80 s after boot in the two recorded conversations from
# PX4's start (HOME_POSITION.time_usec, reference/px4-sitl-boot-timeline.json): arming is taken from then on,
# though the health report says so only at its next interval (4.08-4.18 s there)
READY_S = 3.8
NO_POSITION = ff.Flags(local_position_invalid=True, local_position_invalid_relaxed=True, global_position_invalid=True)
HEALTH_CHECK_S = 0.1  # Commander runs its health and arming checks at 10 Hz
REJECT_PRINT_S = 1.0  # Commander::printRejectMode's interval
ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
TEMPORARILY_REJECTED = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
DENIED = mavlink.MAV_RESULT_DENIED
class Commander:
    def __init__(self, params, now_s, ready_delay_s=READY_S, rc=False):
        self.params = params
        self.boot_s = now_s
        self.now_s = now_s
        self.ready_delay_s = ready_delay_s
        self.ready_announced = False
        self.rc = rc               # an RC receiver is simulated (always on)
        self.manual_control = ManualControlInput(params)  # a ground station's joystick (MANUAL_CONTROL)
        self.landed = True         # the land detector's word, kept current by the flight stack
        self.maybe_landed = True   # ... and its maybe-landed stage
        self.has_mission = False   # a valid mission is loaded, kept current by the flight stack
        self.battery_warning = WARNING_NONE  # the battery's warning, kept current by the flight stack
        self.geofence_result = frozenset()   # the navigator's breaches ('custom', 'max_dist', 'max_alt'), likewise
        self.position_valid = True  # the estimator's local and global position, likewise
        self.armed = False
        self.armed_s = None
        self.takeoff_detected = False
        self.landed_s = None
        self.failsafe = False
        self.failures = set()
        self.events = []
        self.offboard_s = None
        self.offboard_needs_position = False  # the last setpoint controls position (OffboardChecks)
        self.user_mode = self.nav_mode = self.fallback_mode = 'AUTO.LOITER'
        self.mode_change_requested = False
        self.reject_printed_s = None
        self.logger = LoggerStatus(now_s)
        self.data_link = DataLink(params, now_s)  # no ground station at boot
        self.flags = ff.Flags(manual_control_signal_lost=not rc, offboard_control_signal_lost=True,
                              gcs_connection_lost=True)
        self.failsafe_state = fs.Failsafe(params)
        self.failsafe_state.on_notify_user = lambda: self.health.report_if_unreported(self.now_s)
        self.health = HealthReport(first_s=now_s + min(FIRST_REPORT_S, ready_delay_s))
        self.health_checked_s = None
        self.last_battery_warning = WARNING_NONE  # Commander::battery_status_check's _battery_warning
        self.health.update(now_s, self._failing_checks())  # published at once only when ready at boot

    # -- what the link reports ---------------------------------------------------------------

    def system_status(self, now_s):
        if self.armed:
            return mavlink.MAV_STATE_CRITICAL if self.failsafe else mavlink.MAV_STATE_ACTIVE
        return mavlink.MAV_STATE_STANDBY if self.prearm_ok(now_s) else mavlink.MAV_STATE_UNINIT

    def ready(self, now_s):
        return now_s - self.boot_s >= self.ready_delay_s

    def prearm_ok(self, now_s):
        """The pre-arm checks pass (PX4 runs them armed or not; a disarm leaves them passing)."""
        return self._prearm_failure(now_s)[0] is None and self.health.can_arm

    def health_published(self):
        """The commander has published a health report (SYS_STATUS shows none present before)."""
        return self.health.published

    def gps_present(self):
        """SYS_STATUS's GPS present and enabled bits: the reported estimator fuses GPS."""
        return self.health.estimator_ready

    def unhealthy_sensors(self):
        """SYS_STATUS health bits the reported checks clear (the battery's, with a battery warning)."""
        return self.health.unhealthy_bits

    def logging(self, now_s):
        """The logger runs (SYS_STATUS's LOGGING present and enabled bits)."""
        return self.logger.running(now_s)

    def offboard_signal(self, now_s):
        return self.offboard_s is not None and now_s - self.offboard_s <= self.params['COM_OF_LOSS_T']

    def _say(self, severity, text, on_link=True):
        self.events.append(ev.StatusText(severity, text, on_link))

    def _event(self, severity, text):
        """What PX4 main says through its events only. Its mavlink_log lines (arming, takeoff, landing,
        disarm, failsafes) are `_say`'s: STATUSTEXT where a ground station listens, so never to mavros (in a
        whole recorded tutorial flight no STATUSTEXT reached the onboard link, reference/px4-sitl-measured.md
        "The onboard link"; a GCS got "Landing detected" and "Disarmed by landing", "Turn 4 recordings")."""
        self._say(severity, text, on_link=False)

    # -- mode changes -----------------------------------------------------------------------

    def _enter(self, mode):
        """The user's mode becomes `mode` (UserModeIntention::change); the failsafe state decides what flies."""
        self.user_mode = mode
        if mode not in TRANSIENT_MODES:
            self.fallback_mode = mode
        self.mode_change_requested = True
        self._update_failsafe(self.now_s)

    def _update_failsafe(self, now_s):
        """Commander::handleModeIntentionAndFailsafe: the failsafe state's action sets the mode flying."""
        state = self.failsafe_state
        user_mode = state.update(now_s, self.armed, self.user_mode, self.mode_change_requested, self.flags)
        self.mode_change_requested = False
        if user_mode != self.user_mode:  # a takeover or an action changed the user's mode
            self.user_mode = user_mode
            if user_mode not in TRANSIENT_MODES:
                self.fallback_mode = user_mode
        for severity, text, on_link in state.notices:
            self._say(severity, text, on_link)
        state.notices.clear()
        action = state.selected
        if action == ff.Action.DISARM and self.armed:
            self._disarm('failsafe', now_s)  # Commander::disarm(failsafe, forced)
            return
        mode = 'TERMINATION' if action == ff.Action.TERMINATE else ff.mode_from_action(action, self.user_mode)
        mode = FLOWN_AS.get(mode, mode)
        self.failsafe = state.in_failsafe()
        if mode != self.nav_mode:
            self.nav_mode = mode
            self.events.append(ev.ModeChanged(mode, self.failsafe))

    def request_mode(self, mode, now_s):
        """A user's mode request (SET_MODE, DO_SET_MODE, a command); returns a MAV_RESULT."""
        self.now_s = now_s
        if mode is None or mode in REFUSED_MODES:
            self._say(mavlink.MAV_SEVERITY_CRITICAL, 'Switching to %s is not supported' % (mode or 'an unknown mode'))
            return TEMPORARILY_REJECTED
        if self.nav_mode == 'TERMINATION':  # UserModeIntention::change: never out of termination
            return TEMPORARILY_REJECTED
        if mode == self.nav_mode and not self.failsafe:
            return ACCEPTED
        self._update_flags(now_s)  # the checks run for a mode request
        if self.armed and not (
                (mode != 'OFFBOARD' or self.offboard_signal(now_s))
                and (mode not in px4_modes.MANUAL_MODES or self._rc_signal())
                and (mode != 'AUTO.MISSION' or self.has_mission) and ff.mode_can_run(self.flags, mode)):
            self._print_reject_mode(mode, now_s)
            # a refused request is still a request: in a failsafe the pilot may take over with it
            self.mode_change_requested = True
            return TEMPORARILY_REJECTED
        self._enter(mode)
        return ACCEPTED

    def _print_reject_mode(self, mode, now_s):
        """Commander::printRejectMode: at most one line a second."""
        if self.reject_printed_s is None or now_s - self.reject_printed_s > REJECT_PRINT_S:
            self.reject_printed_s = now_s
            self._say(mavlink.MAV_SEVERITY_CRITICAL, 'Switching to %s is currently not available\t'
                      % NAV_STATE_NAMES.get(mode, mode))

    def request_base_mode(self, base_mode, main_mode, sub_mode, now_s):
        """DO_SET_MODE / SET_MODE fields (set_mode_target) -> request_mode."""
        mode, unsupported = set_mode_target(base_mode, main_mode, sub_mode)
        if unsupported:
            self._say(mavlink.MAV_SEVERITY_CRITICAL, unsupported)
            return TEMPORARILY_REJECTED
        return self.request_mode(mode, now_s)

    def return_to_launch(self, now_s):
        """VEHICLE_CMD_NAV_RETURN_TO_LAUNCH, from a ground station or a mission's item (Commander::handle_command):
        AUTO.RTL, "Returning to launch" when taken."""
        result = self.request_mode('AUTO.RTL', now_s)
        if result == ACCEPTED:
            self._say(mavlink.MAV_SEVERITY_INFO, 'Returning to launch\t')
        return result

    def terminate(self, now_s):
        """DO_FLIGHTTERMINATION with param1 > 0.5 (Commander::handle_command): DENIED while disarmed,
        else TERMINATION, the motors off, and no way out of it."""
        if not self.armed:
            return DENIED
        return self.request_mode('TERMINATION', now_s)

    def takeoff_complete(self):
        """The navigator reached the takeoff altitude: loiter there, as PX4 does."""
        self._say(mavlink.MAV_SEVERITY_INFO, 'Takeoff complete')
        self._enter('AUTO.LOITER')

    # -- arming -----------------------------------------------------------------------------

    def request_arming(self, arm, force, now_s):
        self.now_s = now_s
        if arm:
            if self.armed:
                return ACCEPTED
            # a command from a link always runs Commander::arm's stick checks, forced or not (run_preflight_checks
            # is from_external || !forced); the force magic skips the others
            reason, result = self.manual_control.arming_refusal(self.nav_mode, self.flags.manual_control_signal_lost)
            if not force and not reason:
                reason, result = self._arming_refusal(now_s)
            if reason:
                self._say(mavlink.MAV_SEVERITY_CRITICAL, 'Arming denied: ' + reason)
                return result
            self._arm(now_s)
            return ACCEPTED
        if not self.armed:
            return ACCEPTED
        if not force and not (self.landed or self.maybe_landed):
            # PX4's Commander::disarm: TRANSITION_DENIED, which the command answers TEMPORARILY_REJECTED
            self._say(mavlink.MAV_SEVERITY_CRITICAL, 'Disarming denied: not landed\t')
            return TEMPORARILY_REJECTED
        self._disarm('external command', now_s)
        return ACCEPTED

    def _arming_refusal(self, now_s):
        reason, result = self._prearm_failure(now_s)
        if reason:
            return reason, result
        self._update_flags(now_s)  # Commander::arm runs the checks and takes can_arm as they stand
        if any(check.blocks_arming for check in self._failing_checks()):
            return 'Resolve system health failures first', TEMPORARILY_REJECTED
        if self.nav_mode in NOT_ARMABLE:
            return 'mode %s is not armable' % self.nav_mode, TEMPORARILY_REJECTED
        if not self.landed:
            return 'vehicle not landed', DENIED
        return None, ACCEPTED

    def _prearm_failure(self, now_s):
        """(reason, MAV_RESULT) of the first failing pre-arm check, (None, ACCEPTED) when all pass."""
        if not self.ready(now_s):  # EKF2 has no position yet: modeCheck fails for every mode that needs one
            return 'Resolve system health failures first\t', TEMPORARILY_REJECTED
        if self.failures:
            return 'Resolve system health failures first (%s)' % ', '.join(sorted(self.failures)), \
                TEMPORARILY_REJECTED
        if self.nav_mode == 'OFFBOARD' and not self.offboard_signal(now_s):
            return 'Resolve system health failures first (no offboard signal)', TEMPORARILY_REJECTED
        if self.nav_mode in px4_modes.MANUAL_MODES and not self._rc_signal():
            return 'no manual control', TEMPORARILY_REJECTED
        if self.nav_mode == 'AUTO.MISSION' and not self.has_mission:
            return 'no valid mission', TEMPORARILY_REJECTED
        if not self.position_valid and not ff.mode_can_run(NO_POSITION, self.nav_mode):
            return 'mode %s needs a position' % self.nav_mode, TEMPORARILY_REJECTED
        return None, ACCEPTED

    def _arm(self, now_s):
        self.armed, self.armed_s = True, now_s
        self.logger.on_arm(now_s)
        self.takeoff_detected, self.landed_s = False, None
        self.events.append(ev.ArmingChanged(True, 'commanded'))
        self._say(mavlink.MAV_SEVERITY_INFO, 'Armed by external command\t')
        self._update_failsafe(now_s)

    def _disarm(self, why, now_s):
        """Commander::disarm; `why` as PX4's arm_disarm_reason_str says it."""
        self.armed = False
        self.logger.on_disarm(now_s)
        self.takeoff_detected, self.landed_s = False, None
        self.events.append(ev.ArmingChanged(False, why))
        self._say(mavlink.MAV_SEVERITY_INFO, 'Disarmed by %s\t' % why)
        if self.user_mode in TRANSIENT_MODES:  # UserModeIntention::onDisarm
            self.user_mode = self.fallback_mode
        self._update_failsafe(now_s)

    def mission_landed(self, now_s):
        """The mission ended with a landing and the vehicle is down: disarm at once, as PX4 does."""
        if self.armed and self.landed and self.nav_mode == 'AUTO.MISSION':
            self._disarm('landing', now_s)

    def inject_failure(self, name, failed):
        """A sensor failure (MAV_CMD_INJECT_FAILURE that SimulatorMavlink takes): its checks fail, arming is refused."""
        if failed:
            self.failures.add(name)
        else:
            self.failures.discard(name)

    def on_offboard_setpoint(self, now_s):
        """An accepted setpoint refreshes the offboard signal."""
        self.offboard_s = now_s

    def on_gcs_heartbeat(self, now_s):
        """A ground station's HEARTBEAT (MAV_TYPE_GCS from another system) on any link."""
        self.data_link.on_gcs_heartbeat(now_s)

    def on_manual_control(self, now_s, sticks=None):
        """MANUAL_CONTROL from a ground station, with its sticks (sim.manual_control.ManualControlSetpoint) when known."""
        self.manual_control.on_sample(now_s, sticks)

    def manual_control_signal(self):
        """A ground station's MANUAL_CONTROL is still taken (sim.manual_control_input)."""
        return self.manual_control.signal(self.now_s)

    def _rc_signal(self):
        """Manual control is there: the simulated RC, or MANUAL_CONTROL that PX4's ManualControl still takes."""
        return self.rc or self.manual_control_signal()

    # -- the periodic checks ------------------------------------------------------------------

    def check(self, now_s):
        """Before the vehicle steps, as Commander::run: the data link and the battery, the failsafe state
        on the conditions of the last checks, then the health and arming checks (10 Hz: a condition
        reaches the failsafe state up to 0.1 s after it arose, and a failsafe that notifies the pilot
        finds the check's report waiting)."""
        self.now_s = now_s
        if not self.ready_announced and self.ready(now_s):
            self.ready_announced = True
            self._event(mavlink.MAV_SEVERITY_INFO, 'Ready for takeoff!')
        for severity, text in self.data_link.check(now_s):
            self._say(severity, text)
        self._battery_status_check()
        self._update_failsafe(now_s)
        if self.health_checked_s is None or now_s - self.health_checked_s >= HEALTH_CHECK_S - 1e-9:
            self.health_checked_s = now_s
            self._update_flags(now_s)
            for severity, text in self.health.update(now_s, self._failing_checks()):
                self._say(severity, text)

    def _battery_status_check(self):
        """Commander::battery_status_check: an emergency level asks the board to shut down, which PX4 SITL
        cannot ("System does not support shutdown", recorded)."""
        warning = self.flags.battery_warning
        if warning != self.last_battery_warning and warning == WARNING_EMERGENCY:
            self._say(mavlink.MAV_SEVERITY_CRITICAL, 'System does not support shutdown\t')
        self.last_battery_warning = warning

    def _update_flags(self, now_s):
        """The conditions PX4's checks put in failsafe_flags_s (batteryCheck: armed, the warning only grows)."""
        f = self.flags
        invalid = not self.position_valid
        # OffboardChecks: position setpoints need a valid position to count as an offboard signal
        f.offboard_control_signal_lost = not self.offboard_signal(now_s) or (self.offboard_needs_position and invalid)
        f.manual_control_signal_lost = not self._rc_signal()
        f.gcs_connection_lost = self.data_link.lost
        f.geofence_breached = bool(self.geofence_result)
        f.auto_mission_missing = not self.has_mission
        f.battery_warning = max(f.battery_warning, self.battery_warning) if self.armed else self.battery_warning
        f.local_position_invalid = f.local_position_invalid_relaxed = f.global_position_invalid = invalid

    def _failing_checks(self):
        return failing_checks(self.flags, self.data_link.lost, self.geofence_result, self.params,
                              self.ready(self.now_s))

    def check_landing(self, now_s):
        """After the vehicle stepped: takeoff and landing detection, the auto-disarm timers."""
        self.now_s = now_s
        if not self.armed:
            return
        p = self.params
        if not self.landed:
            if not self.takeoff_detected:
                self.takeoff_detected = True
                self._say(mavlink.MAV_SEVERITY_INFO, 'Takeoff detected\t')
            self.landed_s = None
            return
        if not self.takeoff_detected:
            limit = p['COM_DISARM_PRFLT']
            if limit > 0 and now_s - self.armed_s >= limit:
                self._disarm('auto preflight disarming', now_s)
            return
        if self.landed_s is None:
            self.landed_s = now_s
            self._say(mavlink.MAV_SEVERITY_INFO, 'Landing detected\t')
        limit = p['COM_DISARM_LAND']
        if limit >= 0 and now_s - self.landed_s >= limit:
            self._disarm('landing', now_s)
