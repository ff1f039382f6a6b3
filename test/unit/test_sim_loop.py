"""The simulated PX4's loop (offboard_py.sim.loop) when its process cannot keep up: a stall of more than
STALL_S behind the clock skips the missed steps, and says so with how many, at any speed."""

import logging
import re
import time

from offboard_py.sim import loop


class Clock:
    """Wall time, plus whatever stall() adds: the loop finds itself that far behind at once."""

    def __init__(self):
        self.extra_s = 0.0

    def __call__(self):
        return time.monotonic() + self.extra_s

    def stall(self, seconds):
        self.extra_s += seconds


class CommandSender:
    """A simulated PX4's command sender with nothing deferred."""

    def __init__(self):
        self.deferred = []

    def send_deferred(self, _now=None):
        pass


class Vehicle:
    """What run_together asks of a simulated PX4, counting its steps; the 20th step stalls the process."""

    def __init__(self, clock, system_id):
        self.clock, self.rate_hz, self.steps_per_wakeup = clock, 100.0, 2
        self.links, self.command_sender, self.system_id, self.boot_s = [], CommandSender(), system_id, clock()
        self.running, self.steps = True, 0

    def step(self, _dt, _slot_s=None, _out=None):
        self.steps += 1
        if self.steps == 20 and self.system_id == 1:
            self.clock.stall(1.0)


def test_a_stall_skips_the_missed_steps_and_says_how_many(caplog):
    clock = Clock()
    fleet = [Vehicle(clock, 1), Vehicle(clock, 2)]
    with caplog.at_level(logging.WARNING, logger='offboard_py.sim'):
        loop.run_together(fleet, duration_s=1.6)
    said = [r.getMessage() for r in caplog.records]
    # the 1 s stall less the loop's own slack: 98-100 steps of 10 ms
    assert any(re.search(r'fell (0\.9[89]|1\.0\d) s behind its clock and skipped (98|99|100) steps of its 2 '
                         r'vehicle\(s\)', m) and 'cannot keep up with 2 vehicles in one process (a process runs on one core; multi_uav.launch '
               'vehicles_per_sim sets how many share one)' in m
               for m in said), said
    # the totals at the end (a real hiccup of this process over 0.25 s would add a stall of its own)
    totals = [re.search(r'skipped (\d+) steps of each vehicle, their streams with them, in (\d+) stalls', m) for m in said]
    assert any(t and int(t.group(1)) >= 98 and int(t.group(2)) >= 1 for t in totals), said
    # 1.6 s of the clock at 100 Hz is 160 steps: the stall's 98-100 skipped, not run in a burst after it,
    # the other 60 or so run (with the step the loop takes on resynchronising and a few of its own slack)
    assert all(58 <= v.steps <= 66 for v in fleet), [v.steps for v in fleet]


def test_a_loop_that_keeps_up_says_nothing(caplog):
    clock = Clock()
    fleet = [Vehicle(clock, 3)]
    start = time.monotonic()
    with caplog.at_level(logging.WARNING, logger='offboard_py.sim'):
        loop.run_together(fleet, duration_s=0.5)
    ran_s = time.monotonic() - start
    assert not [r for r in caplog.records if 'behind' in r.getMessage() or 'skipped' in r.getMessage()]
    # a step per 10 ms slot of the wall time it ran: 0.5 s, and more when a busy machine wakes the last
    # wake-up late (a late wake-up under STALL_S runs the slots due, as it should, and none skipped)
    slots = ran_s / 0.01
    assert 48 <= fleet[0].steps and slots - 3 <= fleet[0].steps <= slots + 1.5, (fleet[0].steps, ran_s)
