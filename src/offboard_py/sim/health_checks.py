"""How the simulated PX4 reports its health and arming checks, as PX4's HealthAndArmingChecks and its Report
(src/modules/commander/HealthAndArmingChecks/HealthAndArmingChecks.cpp, Common.cpp, PX4 main 02e73e3b6f).

The commander lists the checks failing now (`Check`: the event, its mavlink_log line, the SYS_STATUS health
bits it clears, whether it stops arming); a changed list is reported at most every MIN_REPORTING_INTERVAL_S
(Report::report). A report publishes the health (what SYS_STATUS and the PREARM_CHECK bit show) and, run a
second time with the mavlink_log publication set (the LEGACY block), sends the STATUSTEXT line of every check
failing then, not only of the new one. A change inside the interval waits for the next report; a failsafe
notification reports it at once (Commander::onFailsafeNotifyUser -> reportIfUnreportedDifferences) but
that report sends events only: no STATUSTEXT and no new health, and the interval starts again from it.

So a battery switched off in flight says "Low battery" at once, its CRITICAL level only as an event with
the failsafe, and "Emergency battery level" 2 s after that failsafe (reference/px4-sitl-measured.md,
"Turn 4 recordings", item 6). Pure: time is passed in.
"""

from typing import NamedTuple

from offboard_py.dialect import mavlink
from offboard_py.sim.battery_simulator import WARNING_CRITICAL, WARNING_EMERGENCY, WARNING_LOW

MIN_REPORTING_INTERVAL_S = 2.0  # Report's min_reporting_interval default
# The first health_report after boot, in both recorded conversations from PX4's start (reference/
# px4-sitl-boot-timeline.json): SYS_STATUS showed a zeroed report (present 0) until a message in 1.96-2.05 s
# of boot; the next report, with the estimator ready, came at its 2 s interval after that
FIRST_REPORT_S = 2.0


class Check(NamedTuple):
    """One failing check: `event` names it (PX4's event id); `text` is its mavlink_log line (None: an event
    only) at `severity`; `health_bits` the SYS_STATUS sensors it marks unhealthy; `blocks_arming` when it
    clears can_arm for every mode."""
    event: str
    severity: int
    text: str
    health_bits: int = 0
    blocks_arming: bool = False


# the checks' STATUSTEXT lines and what they clear (HealthAndArmingChecks/checks/*.cpp)
BATTERY_CHECKS = {
    WARNING_LOW: Check('check_battery_low', mavlink.MAV_SEVERITY_CRITICAL, 'Low battery\t',
                       mavlink.MAV_SYS_STATUS_SENSOR_BATTERY, False),
    WARNING_CRITICAL: Check('check_battery_critical', mavlink.MAV_SEVERITY_CRITICAL, 'Critical battery\t',
                            mavlink.MAV_SYS_STATUS_SENSOR_BATTERY, True),
    WARNING_EMERGENCY: Check('check_battery_emergency', mavlink.MAV_SEVERITY_EMERGENCY, 'Emergency battery level\t',
                             mavlink.MAV_SYS_STATUS_SENSOR_BATTERY, True),
}
NO_GCS_CHECK = Check('check_rc_dl_no_dllink', mavlink.MAV_SEVERITY_WARNING,
                     'Preflight Fail: No connection to the GCS', 0, True)
# modeCheck.cpp, while EKF2 has no position yet (an event only: "Navigation error: No valid position estimate");
# it marks the local position estimate unhealthy (SYS_STATUS's XY_POSITION_CONTROL) and stops arming
ESTIMATOR_CHECK = Check('check_modes_local_pos', mavlink.MAV_SEVERITY_ERROR, None,
                        mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL, True)
GEOFENCE_CHECK = Check('check_gf_violation_custom_gf', mavlink.MAV_SEVERITY_CRITICAL,
                       'Geofence: approaching or outside geofence', 0, True)
GEOFENCE_DISTANCE_CHECK = Check('check_gf_violation_max_hor_dist', mavlink.MAV_SEVERITY_CRITICAL,
                                'Geofence: exceeding maximum distance to Home', 0, True)
GEOFENCE_ALTITUDE_CHECK = Check('check_gf_violation_max_alt', mavlink.MAV_SEVERITY_CRITICAL,
                                'Geofence: exceeding maximum altitude above Home', 0, True)


def failing_checks(flags, gcs_connection_lost, geofence_result, params, estimator_ready=True):
    """The checks failing on these conditions (failsafe_flags_s, the data link, the navigator's geofence
    breaches, the estimator's start): modeCheck's position check until EKF2 is ready, batteryCheck,
    rcAndDataLinkCheck (only where NAV_DLL_ACT acts), geofenceCheck (only where GF_ACTION does)."""
    checks = [] if estimator_ready else [ESTIMATOR_CHECK]
    if flags.battery_warning in BATTERY_CHECKS:
        checks.append(BATTERY_CHECKS[flags.battery_warning])
    if gcs_connection_lost and params['NAV_DLL_ACT'] > 0:
        checks.append(NO_GCS_CHECK)
    if params['GF_ACTION'] != 0:
        for breach, check in (('max_dist', GEOFENCE_DISTANCE_CHECK), ('max_alt', GEOFENCE_ALTITUDE_CHECK),
                              ('custom', GEOFENCE_CHECK)):
            if breach in geofence_result:
                checks.append(check)
    return checks


class HealthReport:
    """The last reported health and the rate limit of reports. Nothing is reported before `first_s`:
    until then SYS_STATUS shows a zeroed health_report (no sensor present, every one healthy)."""

    def __init__(self, first_s=None):
        self.current = frozenset()
        self.reported = frozenset()  # what the last published health_report held
        self.last_report_s = None
        self.first_s = first_s
        self.unreported = False

    @property
    def published(self):
        """A health_report has been published (SYS_STATUS's present and enabled words come from it)."""
        return self.last_report_s is not None

    @property
    def estimator_ready(self):
        """The published report has the estimator fusing GPS: estimatorCheck.cpp sets the GPS present
        only then (its health bit is set from the start: no check fails on it)."""
        return self.published and ESTIMATOR_CHECK not in self.reported

    @property
    def unhealthy_bits(self):
        """SYS_STATUS health bits the reported checks clear."""
        bits = 0
        for check in self.reported:
            bits |= check.health_bits
        return bits

    @property
    def can_arm(self):
        """The reported can_arm for every mode (SYS_STATUS's PREARM_CHECK)."""
        return not any(check.blocks_arming for check in self.reported)

    def update(self, now_s, checks):
        """The checks failing now; returns [(severity, text)] of the STATUSTEXT lines a report sends."""
        checks = frozenset(checks)
        changed = checks != self.current
        self.current = checks
        if not self._report(now_s, changed, force=False):
            return []
        self.reported = checks
        return [(c.severity, c.text) for c in sorted(checks) if c.text]

    def report_if_unreported(self, now_s):
        """A failsafe is about to be announced: a change waiting for its interval is reported now, as
        events only (no STATUSTEXT, the published health unchanged)."""
        if self.unreported:
            self._report(now_s, False, force=True)

    def _report(self, now_s, changed, force):
        difference = self.unreported or changed
        if self.first_s is not None and now_s < self.first_s - 1e-9:
            self.unreported = self.unreported or difference
            return False
        if self.last_report_s is None:  # the first report: published whatever it holds
            difference = True
        if (self.last_report_s is not None and now_s < self.last_report_s + MIN_REPORTING_INTERVAL_S
                and not force):
            self.unreported = self.unreported or difference
            return False
        if not (difference or force):
            return False
        self.last_report_s = now_s
        self.unreported = False
        return True
