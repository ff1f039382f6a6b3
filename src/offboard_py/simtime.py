"""Simulated time: one clock that every process of a run reads.

At speed K the simulated time is K times the host's monotonic clock:

    sim_s = K * time.monotonic()

governed (offboard_py.clock_board) so that it never runs further ahead of the run's slowest participant
than a lead: a process starved of CPU holds the clock instead of missing a simulated deadline. Where a run
has no board (real time under ROS, a process on its own) the formula alone is the clock.

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
    """Simulated seconds at `speed` times the monotonic clock (speed 1 without a board is time.monotonic()
    itself), held by the run's clock board when it has one (`board`, or SimClock.for_run)."""

    POLL_WALL_S = 0.01  # a sleep on a governed clock looks again this often (wall): the clock may be held

    def __init__(self, speed=1.0, monotonic=time.monotonic, sleep=time.sleep, board=None):
        self.speed = parse_speed(speed)
        self._monotonic = monotonic
        self._sleep = sleep
        self.board = board
        self.participant = None

    @classmethod
    def for_run(cls, speed, name=None, environ=os.environ, strict=True):
        """The clock of the run this process is in: its board (offboard_py.clock_board.board_path) when it
        has one, joined as participant `name` when given. A board that cannot be used raises
        clock_board.BoardError, or with strict=False leaves this process on speed x the monotonic clock."""
        from offboard_py import clock_board  # no board, no mmap
        speed = parse_speed(speed)
        path = clock_board.board_path(speed, environ)
        try:
            board = clock_board.Board(path, speed) if path else None
        except clock_board.BoardError:
            if strict:
                raise
            board = None
        clock = cls(speed, board=board)
        if name and clock.board is not None:
            clock.participant = clock.board.join(name)
        return clock

    @property
    def real_time(self):
        return self.speed == 1.0 and self.board is None

    def now(self):
        if self.board is not None:
            return self.board.now()
        return self.speed * self._monotonic()

    __call__ = now

    def at_monotonic(self, mono_s):
        """The simulated time at the monotonic instant mono_s (in the past: a kernel's receive stamp)."""
        if self.board is not None:
            return self.board.at(mono_s)
        return self.speed * mono_s

    def progress(self, sim_s=None):
        """As a participant: this process has got to sim_s (default: now)."""
        if self.participant is not None:
            self.participant.update(self.now() if sim_s is None else sim_s)

    def leave(self):
        if self.participant is not None:
            self.participant.leave()
            self.participant = None

    def wall_s(self, sim_s):
        """Wall seconds that `sim_s` simulated seconds take."""
        return sim_s / self.speed

    def sim_s(self, wall_s):
        return wall_s * self.speed

    def sleep(self, sim_s):
        if sim_s <= 0:
            return
        if self.board is None:
            self._sleep(sim_s / self.speed)
            return
        end = self.now() + sim_s
        while True:
            left = end - self.now()
            if left <= 0:
                return
            self.progress()
            self._sleep(min(left / self.speed, self.POLL_WALL_S))

    def __repr__(self):
        return 'SimClock(speed=%g%s)' % (self.speed, ', board %s' % self.board.path if self.board else '')
