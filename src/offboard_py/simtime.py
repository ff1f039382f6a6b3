"""Simulated time: one clock that every process of a run computes for itself.

At speed K the simulated time is K times the host's monotonic clock:

    sim_s = K * time.monotonic()

CLOCK_MONOTONIC is one clock for every process on the host, so the simulated PX4 (which
steps its model, timers and time_boot_ms on it), the /clock publisher and a test's
deadlines all read the same simulated second without talking to one another: several
vehicles share one clock by construction, a restarted simulator or bridge joins it where it
is, and no datagram or topic carries the clock between them. The ROS side follows /clock
(use_sim_time), which sim_clock publishes from this formula.

Speed 1 is real time: nothing uses /clock and every process runs as it always did.
No ROS, no MAVLink here.
"""
import argparse
import math
import os
import time

SPEED_ENV = 'OFFBOARD_PY_SPEED'


class SpeedError(ValueError):
    """A speed that is not a finite number > 0."""


def parse_speed(text, what='speed'):
    """The speed factor in `text` (a str or number): a finite number > 0, or SpeedError naming it."""
    try:
        speed = float(text)
    except (TypeError, ValueError):
        raise SpeedError('%s must be a number > 0 (1 is real time), got %r' % (what, text)) from None
    if not math.isfinite(speed) or speed <= 0.0:
        raise SpeedError('%s must be a finite number > 0 (1 is real time), got %r' % (what, text))
    return speed


def speed_option(text):
    """parse_speed() as an argparse type for a --speed option: a bad value is argparse's usage error."""
    try:
        return parse_speed(text, '--speed')
    except SpeedError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def speed_from_env(default=1.0, environ=os.environ):
    """The speed set by OFFBOARD_PY_SPEED (what ./run test exports), else `default`."""
    text = environ.get(SPEED_ENV, '').strip()
    return parse_speed(text, SPEED_ENV) if text else default


class SimClock:
    """Simulated seconds at `speed` times the monotonic clock; speed 1 is time.monotonic() itself."""

    def __init__(self, speed=1.0, monotonic=time.monotonic, sleep=time.sleep):
        self.speed = parse_speed(speed)
        self._monotonic = monotonic
        self._sleep = sleep

    @property
    def real_time(self):
        return self.speed == 1.0

    def now(self):
        return self.speed * self._monotonic()

    __call__ = now

    def wall_s(self, sim_s):
        """Wall seconds that `sim_s` simulated seconds take."""
        return sim_s / self.speed

    def sim_s(self, wall_s):
        return wall_s * self.speed

    def sleep(self, sim_s):
        if sim_s > 0:
            self._sleep(sim_s / self.speed)

    def __repr__(self):
        return 'SimClock(speed=%g)' % self.speed
