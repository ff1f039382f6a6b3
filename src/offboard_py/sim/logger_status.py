"""Whether PX4's logger runs, for SYS_STATUS's MAV_SYS_STATUS_LOGGING present and enabled bits (SDLOG_MODE 1:
from boot until the first disarm, then from each arming to its disarm). Pure: time is passed in."""

# The logger's bit in SYS_STATUS (reference/px4-sitl-measured.md, "Turn 3 recordings", section 6):
# back about 0.3 s after arming; gone 3.9 s, 4.1 s and 2.2 s after disarms that ended logs of
# about 2.6 s (or since boot), 1.9 s and 0.6 s. PX4's LoggerChecks counts the logger as running
# while its last status is under 3 s old; how long the logger still writes after a disarm grows
# with what it has buffered. One rule reproduces the three within 10 %: the bit goes
# LOG_CLOSE_BASE_S + LOG_CLOSE_PER_S x (seconds logged) after the disarm, at most LOG_CLOSE_MAX_S
# (2.26, 3.78 and 4.0 s for the three cases).
LOG_START_S = 0.3
LOG_CLOSE_BASE_S, LOG_CLOSE_PER_S, LOG_CLOSE_MAX_S = 1.5, 1.2, 4.0


def log_close_s(logged_s):
    """Seconds from a disarm until the logger's bit goes, for a log that ran `logged_s`."""
    return min(LOG_CLOSE_BASE_S + LOG_CLOSE_PER_S * logged_s, LOG_CLOSE_MAX_S)


class LoggerStatus:
    def __init__(self, boot_s):
        self.start_s, self.stop_s = boot_s, None  # SDLOG_MODE 1: logging from boot

    def running(self, now_s):
        return now_s >= self.start_s and (self.stop_s is None or now_s < self.stop_s)

    def on_arm(self, now_s):
        if not self.running(now_s):  # a log still closing goes on; otherwise a new one starts
            self.start_s = now_s + LOG_START_S
        self.stop_s = None

    def on_disarm(self, now_s):
        self.stop_s = now_s + log_close_s(max(0.0, now_s - self.start_s))
