"""The commander of the simulated PX4: modes, arming, the offboard signal, failsafes, timers.

Rules, as current PX4 applies them (reference/px4-behaviour.md):
- Boots in AUTO.LOITER, disarmed; arming is refused for `ready_delay_s` while the
  estimator settles ("Ready for takeoff" after about 5 s on PX4 SITL).
- HEARTBEAT's system_status as PX4 main reports it (reference/px4-sitl-measured.md, "Turn 3
  recordings", section 6): UNINIT while a pre-arm check fails (before ready, with an injected
  failure, OFFBOARD selected without the offboard signal, a manual mode without RC, AUTO.MISSION
  without a mission), STANDBY disarmed otherwise (straight after a disarm too), ACTIVE armed,
  CRITICAL in a failsafe. `prearm_ok()` is the same verdict, for SYS_STATUS's PREARM_CHECK health bit.
- The logger (SDLOG_MODE 1: from boot until the first disarm, then from each arming to its
  disarm): `logging()` says whether it runs, for SYS_STATUS's MAV_SYS_STATUS_LOGGING present and
  enabled bits; it starts LOG_START_S after an arming and stops log_close_s() after a disarm.
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
  intended mode) and a mode change by the user takes over where the action allows it. The vehicle never
  goes back to OFFBOARD by itself.
- What the checks say goes through PX4's report (sim.health_checks): "Low battery", "Emergency battery
  level", "Geofence: ...", the GCS one, at most every 2 s, with the SYS_STATUS health they clear.
- Arming: refused while not ready, with an injected failure, in OFFBOARD without the
  signal, in a manual mode without RC, in AUTO.MISSION without a mission, in AUTO.LAND
  or AUTO.RTL; DENIED while not landed. Disarming is TEMPORARILY_REJECTED unless the land
  detector says landed or maybe landed (PX4's Commander::disarm; an OFFBOARD takeoff loses
  maybe-landed as its thrust rises). PX4's force magic (21196) skips the checks.
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
from offboard_py.sim.battery_simulator import (WARNING_CRITICAL, WARNING_EMERGENCY, WARNING_LOW, WARNING_NONE)
from offboard_py.sim.health_checks import Check, HealthReport

# names mavros knows (px4_modes.MODES) for which PX4 main has no navigation state
REFUSED_MODES = frozenset(('AUTO.READY', 'AUTO.RTGS', 'RATTITUDE'))
# modes that prevent arming (ModeUtil/mode_requirements.cpp: mode_req_prevent_arming)
NOT_ARMABLE = frozenset(('AUTO.LAND', 'AUTO.RTL', 'AUTO.FOLLOW_TARGET', 'AUTO.PRECLAND', 'TERMINATION'))
# modes the vehicle leaves for the user's previous choice once it is disarmed: those that prevent
# arming and the takeoff, TERMINATION excepted (UserModeIntention::change, _nav_state_after_disarming)
TRANSIENT_MODES = (NOT_ARMABLE | {'AUTO.TAKEOFF'}) - {'TERMINATION'}
# DO_SET_MODE's custom main modes (px4_custom_mode.h) as Commander::handle_command takes them; POSCTL
# and AUTO have their own rules in set_mode_target
_MAIN_MODES = {px4_modes.MAIN_MANUAL: 'MANUAL', px4_modes.MAIN_ALTCTL: 'ALTCTL',
               px4_modes.MAIN_ALTITUDE_CRUISE: 'ALTITUDE_CRUISE', px4_modes.MAIN_ACRO: 'ACRO',
               px4_modes.MAIN_STABILIZED: 'STABILIZED', px4_modes.MAIN_OFFBOARD: 'OFFBOARD'}
_AUTO_SUB_MODES = {px4_modes.SUB_LOITER: 'AUTO.LOITER', px4_modes.SUB_MISSION: 'AUTO.MISSION',
                   px4_modes.SUB_RTL: 'AUTO.RTL', px4_modes.SUB_TAKEOFF: 'AUTO.TAKEOFF',
                   px4_modes.SUB_LAND: 'AUTO.LAND', px4_modes.SUB_FOLLOW_TARGET: 'AUTO.FOLLOW_TARGET',
                   px4_modes.SUB_PRECLAND: 'AUTO.PRECLAND'}
# PX4's Descend (a landing without a position) is AUTO.LAND on MAVLink (px4_custom_mode.h); flown as the landing
FLOWN_AS = {'DESCEND': 'AUTO.LAND'}
# Commander::dataLinkCheck through telemetry_status: a GCS HEARTBEAT counts for HEARTBEAT_TIMEOUT_US, and
# MavlinkReceiver::CheckHeartbeats looks every half of it
GCS_HEARTBEAT_TIMEOUT_S = 2.5
GCS_HEARTBEAT_CHECK_S = GCS_HEARTBEAT_TIMEOUT_S / 2
NO_POSITION = fs.Flags(local_position_invalid=True, local_position_invalid_relaxed=True, global_position_invalid=True)
HEALTH_CHECK_S = 0.1  # Commander runs its health and arming checks at 10 Hz
# the checks' STATUSTEXT lines and what they clear (HealthAndArmingChecks/checks/*.cpp)
BATTERY_CHECKS = {
    WARNING_LOW: Check('check_battery_low', mavlink.MAV_SEVERITY_CRITICAL, 'Low battery',
                       mavlink.MAV_SYS_STATUS_SENSOR_BATTERY, False),
    WARNING_CRITICAL: Check('check_battery_critical', mavlink.MAV_SEVERITY_CRITICAL, 'Critical battery',
                            mavlink.MAV_SYS_STATUS_SENSOR_BATTERY, True),
    WARNING_EMERGENCY: Check('check_battery_emergency', mavlink.MAV_SEVERITY_EMERGENCY, 'Emergency battery level',
                             mavlink.MAV_SYS_STATUS_SENSOR_BATTERY, True),
}
NO_GCS_CHECK = Check('check_rc_dl_no_dllink', mavlink.MAV_SEVERITY_WARNING,
                     'Preflight Fail: No connection to the GCS', 0, True)
GEOFENCE_CHECK = Check('check_gf_violation_custom_gf', mavlink.MAV_SEVERITY_CRITICAL,
                       'Geofence: approaching or outside geofence', 0, True)
GEOFENCE_DISTANCE_CHECK = Check('check_gf_violation_max_hor_dist', mavlink.MAV_SEVERITY_CRITICAL,
                                'Geofence: exceeding maximum distance to Home', 0, True)
GEOFENCE_ALTITUDE_CHECK = Check('check_gf_violation_max_alt', mavlink.MAV_SEVERITY_CRITICAL,
                                'Geofence: exceeding maximum altitude above Home', 0, True)

ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
TEMPORARILY_REJECTED = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
DENIED = mavlink.MAV_RESULT_DENIED
# The logger's bit in SYS_STATUS (reference/px4-sitl-measured.md, "Turn 3 recordings", section 6):
# back about 0.3 s after arming; gone 3.9 s, 4.1 s and 2.2 s after disarms that ended logs of
# about 2.6 s (or since boot), 1.9 s and 0.6 s. PX4's LoggerChecks counts the logger as running
# while its last status is under 3 s old; how long the logger still writes after a disarm grows
# with what it has buffered. One rule reproduces the three within 10 %: the bit goes
# LOG_CLOSE_BASE_S + LOG_CLOSE_PER_S x (seconds logged) after the disarm, at most LOG_CLOSE_MAX_S
# (2.26, 3.78 and 4.0 s for the three cases).
LOG_START_S = 0.3
LOG_CLOSE_BASE_S, LOG_CLOSE_PER_S, LOG_CLOSE_MAX_S = 1.5, 1.2, 4.0


def set_mode_target(base_mode, main_mode, sub_mode):
    """(mode, None) for DO_SET_MODE's base_mode, custom main and sub mode (SET_MODE's too), or
    (None, PX4's text) when PX4 has no such mode, as Commander::handle_command's DO_SET_MODE branch:
    each field cast to a byte; POSCTL with sub mode 2 is Position Slow and with any other POSCTL
    itself (ORBIT, 1, is not reached this way); AUTO with sub mode 0 is the mission, READY, RTGS,
    VTOL_TAKEOFF (a multicopter) and unknown sub modes are refused, as are the main modes
    RATTITUDE (8), SIMPLE (9), TERMINATION (10) and unknown ones. Without the custom mode flag, the
    base mode's flags choose a mission, POSCTL, STABILIZED or MANUAL. The external modes (AUTO
    11-18) are refused: none is registered here."""
    base_mode, main_mode, sub_mode = int(base_mode) & 0xFF, int(main_mode) & 0xFF, int(sub_mode) & 0xFF
    if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
        if base_mode & mavlink.MAV_MODE_FLAG_AUTO_ENABLED:
            return 'AUTO.MISSION', None
        if base_mode & mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED:
            if base_mode & mavlink.MAV_MODE_FLAG_GUIDED_ENABLED:
                return 'POSCTL', None
            if base_mode & mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED:
                return 'STABILIZED', None
            return 'MANUAL', None
        return None, 'Unsupported base mode'
    if main_mode == px4_modes.MAIN_POSCTL:
        return ('POSCTL.SLOW' if sub_mode == px4_modes.SUB_POSCTL_SLOW else 'POSCTL'), None
    if main_mode == px4_modes.MAIN_AUTO:
        if sub_mode == 0:
            return 'AUTO.MISSION', None
        mode = _AUTO_SUB_MODES.get(sub_mode)
        return (mode, None) if mode else (None, 'Unsupported auto mode')
    mode = _MAIN_MODES.get(main_mode)
    return (mode, None) if mode else (None, 'Unsupported main mode')


def log_close_s(logged_s):
    """Seconds from a disarm until the logger's bit goes, for a log that ran `logged_s`."""
    return min(LOG_CLOSE_BASE_S + LOG_CLOSE_PER_S * logged_s, LOG_CLOSE_MAX_S)


class Commander:
    def __init__(self, params, now_s, ready_delay_s=5.0, rc=False):
        self.params = params
        self.boot_s = now_s
        self.now_s = now_s
        self.ready_delay_s = ready_delay_s
        self.ready_announced = False
        self.rc = rc               # an RC receiver is simulated (always on)
        self.manual_control_s = None  # the last MANUAL_CONTROL (a ground station's joystick)
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
        self.log_start_s, self.log_stop_s = now_s, None  # SDLOG_MODE 1: logging from boot
        # the data link: no ground station at boot (Commander's constructor), heard through telemetry_status
        self.gcs_connection_lost = True
        self.gcs_heartbeat_s = None      # the last GCS HEARTBEAT
        self.gcs_seen_s = None           # the last telemetry_status that had one
        self.gcs_checked_s = now_s
        self.flags = fs.Flags(manual_control_signal_lost=not rc, offboard_control_signal_lost=True,
                              gcs_connection_lost=True)
        self.failsafe_state = fs.Failsafe(params)
        self.failsafe_state.on_notify_user = lambda: self.health.report_if_unreported(self.now_s)
        self.health = HealthReport()
        self.health_checked_s = None
        self.last_battery_warning = WARNING_NONE  # Commander::battery_status_check's _battery_warning

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

    def unhealthy_sensors(self):
        """SYS_STATUS health bits the reported checks clear (the battery's, with a battery warning)."""
        return self.health.unhealthy_bits

    def logging(self, now_s):
        """The logger runs (SYS_STATUS's LOGGING present and enabled bits)."""
        return (self.log_start_s is not None and now_s >= self.log_start_s
                and (self.log_stop_s is None or now_s < self.log_stop_s))

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
        if action == fs.Action.DISARM and self.armed:
            self._disarm('failsafe', now_s)  # Commander::disarm(failsafe, forced)
            return
        mode = 'TERMINATION' if action == fs.Action.TERMINATE else fs.mode_from_action(action, self.user_mode)
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
        if self.armed:
            reason = None
            if mode == 'OFFBOARD' and not self.offboard_signal(now_s):
                reason = 'Switching to Offboard is currently not available'
            elif mode in px4_modes.MANUAL_MODES and not self._rc_signal():
                reason = 'Switching to %s is currently not available: no manual control' % mode
            elif mode == 'AUTO.MISSION' and not self.has_mission:
                reason = 'Switching to Mission is currently not available: no valid mission'
            elif not fs.mode_can_run(self.flags, mode):
                reason = 'Switching to %s is currently not available' % mode
            if reason:
                self._say(mavlink.MAV_SEVERITY_CRITICAL, reason)
                # a refused request is still a request: in a failsafe the pilot may take over with it
                self.mode_change_requested = True
                return TEMPORARILY_REJECTED
        self._enter(mode)
        return ACCEPTED

    def request_base_mode(self, base_mode, main_mode, sub_mode, now_s):
        """DO_SET_MODE / SET_MODE fields (set_mode_target) -> request_mode."""
        mode, unsupported = set_mode_target(base_mode, main_mode, sub_mode)
        if unsupported:
            self._say(mavlink.MAV_SEVERITY_CRITICAL, unsupported)
            return TEMPORARILY_REJECTED
        return self.request_mode(mode, now_s)

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
            if not force:
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
            self._say(mavlink.MAV_SEVERITY_CRITICAL, 'Disarming denied: not landed')
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
        if not self.ready(now_s):
            return 'system not ready (estimator initialising)', TEMPORARILY_REJECTED
        if self.failures:
            return 'Resolve system health failures first (%s)' % ', '.join(sorted(self.failures)), \
                TEMPORARILY_REJECTED
        if self.nav_mode == 'OFFBOARD' and not self.offboard_signal(now_s):
            return 'Resolve system health failures first (no offboard signal)', TEMPORARILY_REJECTED
        if self.nav_mode in px4_modes.MANUAL_MODES and not self._rc_signal():
            return 'no manual control', TEMPORARILY_REJECTED
        if self.nav_mode == 'AUTO.MISSION' and not self.has_mission:
            return 'no valid mission', TEMPORARILY_REJECTED
        if not self.position_valid and not fs.mode_can_run(NO_POSITION, self.nav_mode):
            return 'mode %s needs a position' % self.nav_mode, TEMPORARILY_REJECTED
        return None, ACCEPTED

    def _arm(self, now_s):
        self.armed, self.armed_s = True, now_s
        if not self.logging(now_s):  # a log still closing goes on; otherwise a new one starts
            self.log_start_s = now_s + LOG_START_S
        self.log_stop_s = None
        self.takeoff_detected, self.landed_s = False, None
        self.events.append(ev.ArmingChanged(True, 'commanded'))
        self._say(mavlink.MAV_SEVERITY_INFO, 'Armed by external command')
        self._update_failsafe(now_s)

    def _disarm(self, why, now_s):
        """Commander::disarm; `why` as PX4's arm_disarm_reason_str says it."""
        self.armed = False
        logged_s = max(0.0, now_s - self.log_start_s) if self.log_start_s is not None else 0.0
        self.log_stop_s = now_s + log_close_s(logged_s)
        self.takeoff_detected, self.landed_s = False, None
        self.events.append(ev.ArmingChanged(False, why))
        self._say(mavlink.MAV_SEVERITY_INFO, 'Disarmed by %s' % why)
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
        self.gcs_heartbeat_s = now_s

    def on_manual_control(self, now_s):
        """MANUAL_CONTROL from a ground station (PX4 SITL's COM_RC_IN_MODE 1: MAVLink manual control only)."""
        self.manual_control_s = now_s

    def _rc_signal(self):
        """Manual control is there: the simulated RC, or MANUAL_CONTROL younger than COM_RC_LOSS_T
        (RcAndDataLinkChecks)."""
        return self.rc or (self.manual_control_s is not None
                           and self.now_s - self.manual_control_s <= self.params['COM_RC_LOSS_T'])

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
        self._data_link_check(now_s)
        self._battery_status_check()
        self._update_failsafe(now_s)
        if self.health_checked_s is None or now_s - self.health_checked_s >= HEALTH_CHECK_S - 1e-9:
            self.health_checked_s = now_s
            self._update_flags(now_s)
            for severity, text in self.health.update(now_s, self._failing_checks()):
                self._say(severity, text)

    def _data_link_check(self, now_s):
        """Commander::dataLinkCheck: lost when no telemetry_status had a GCS HEARTBEAT for COM_DL_LOSS_T."""
        if now_s - self.gcs_checked_s >= GCS_HEARTBEAT_CHECK_S:
            self.gcs_checked_s = now_s
            if self.gcs_heartbeat_s is not None and now_s - self.gcs_heartbeat_s <= GCS_HEARTBEAT_TIMEOUT_S:
                if self.gcs_connection_lost:
                    self.gcs_connection_lost = False
                    if self.gcs_seen_s is not None:
                        self._say(mavlink.MAV_SEVERITY_INFO, 'GCS connection regained')
                self.gcs_seen_s = now_s
        if (not self.gcs_connection_lost and self.gcs_seen_s is not None
                and now_s - self.gcs_seen_s > self.params['COM_DL_LOSS_T']):
            self.gcs_connection_lost = True
            self._say(mavlink.MAV_SEVERITY_INFO, 'Connection to ground station lost')

    def _battery_status_check(self):
        """Commander::battery_status_check: an emergency level asks the board to shut down, which PX4 SITL
        cannot ("System does not support shutdown", recorded)."""
        warning = self.flags.battery_warning
        if warning != self.last_battery_warning and warning == WARNING_EMERGENCY:
            self._say(mavlink.MAV_SEVERITY_CRITICAL, 'System does not support shutdown')
        self.last_battery_warning = warning

    def _update_flags(self, now_s):
        """The conditions PX4's checks put in failsafe_flags_s (batteryCheck: armed, the warning only grows)."""
        f = self.flags
        invalid = not self.position_valid
        # OffboardChecks: position setpoints need a valid position to count as an offboard signal
        f.offboard_control_signal_lost = not self.offboard_signal(now_s) or (self.offboard_needs_position and invalid)
        f.manual_control_signal_lost = not self._rc_signal()
        f.gcs_connection_lost = self.gcs_connection_lost
        f.geofence_breached = bool(self.geofence_result)
        f.auto_mission_missing = not self.has_mission
        f.battery_warning = max(f.battery_warning, self.battery_warning) if self.armed else self.battery_warning
        f.local_position_invalid = f.local_position_invalid_relaxed = f.global_position_invalid = invalid

    def _failing_checks(self):
        checks = []
        if self.flags.battery_warning in BATTERY_CHECKS:
            checks.append(BATTERY_CHECKS[self.flags.battery_warning])
        if self.gcs_connection_lost and self.params['NAV_DLL_ACT'] > 0:
            checks.append(NO_GCS_CHECK)
        if self.params['GF_ACTION'] != 0:
            for breach, check in (('max_dist', GEOFENCE_DISTANCE_CHECK), ('max_alt', GEOFENCE_ALTITUDE_CHECK),
                                  ('custom', GEOFENCE_CHECK)):
                if breach in self.geofence_result:
                    checks.append(check)
        return checks

    def check_landing(self, now_s):
        """After the vehicle stepped: takeoff and landing detection, the auto-disarm timers."""
        self.now_s = now_s
        if not self.armed:
            return
        p = self.params
        if not self.landed:
            if not self.takeoff_detected:
                self.takeoff_detected = True
                self._say(mavlink.MAV_SEVERITY_INFO, 'Takeoff detected')
            self.landed_s = None
            return
        if not self.takeoff_detected:
            limit = p['COM_DISARM_PRFLT']
            if limit > 0 and now_s - self.armed_s >= limit:
                self._disarm('auto preflight disarming', now_s)
            return
        if self.landed_s is None:
            self.landed_s = now_s
            self._say(mavlink.MAV_SEVERITY_INFO, 'Landing detected')
        limit = p['COM_DISARM_LAND']
        if limit >= 0 and now_s - self.landed_s >= limit:
            self._disarm('landing', now_s)
