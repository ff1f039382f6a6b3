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

MIN_REPORTING_INTERVAL_S = 2.0  # Report's min_reporting_interval default


class Check(NamedTuple):
    """One failing check: `event` names it (PX4's event id); `text` is its mavlink_log line (None: an event
    only) at `severity`; `health_bits` the SYS_STATUS sensors it marks unhealthy; `blocks_arming` when it
    clears can_arm for every mode."""
    event: str
    severity: int
    text: str
    health_bits: int = 0
    blocks_arming: bool = False


class HealthReport:
    """The last reported health and the rate limit of reports."""

    def __init__(self):
        self.current = frozenset()
        self.reported = frozenset()  # what the last published health_report held
        self.last_report_s = None
        self.unreported = False

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
        if (self.last_report_s is not None and now_s < self.last_report_s + MIN_REPORTING_INTERVAL_S
                and not force):
            self.unreported = self.unreported or difference
            return False
        if not (difference or force):
            return False
        self.last_report_s = now_s
        self.unreported = False
        return True
