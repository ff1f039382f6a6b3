"""The session's governed clock (offboard_py.clock_board) with a real simulated PX4 and a participant that stops:
the clock (and the vehicle's own time_boot_ms) waits for it, goes on when it comes back, and goes on without
it once it has been silent for the board's stale time. The participant is a process of its own, stopped
with SIGSTOP as the kernel stops a process it gives no CPU."""

import os
import signal
import subprocess
import sys
import time

import pytest

from offboard_py import clock_board

PARTICIPANT = '''
import sys, time
from offboard_py.clock_board import Board, ThreadParticipant
board = Board(sys.argv[1], float(sys.argv[2]))
ThreadParticipant(board, 'stopped on purpose')
print('joined', flush=True)
time.sleep(600)
'''


@pytest.fixture
def participant(sim_px4):
    path = os.environ.get(clock_board.BOARD_ENV)
    if not path:
        pytest.skip('no governed clock in this session (OFFBOARD_PY_CLOCK_BOARD is empty)')
    proc = subprocess.Popen([sys.executable, '-c', PARTICIPANT, path, '%g' % sim_px4.clock.speed],
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == 'joined'
        yield proc
    finally:
        proc.kill()
        proc.wait(10)


def boot_s(client):
    """The vehicle's own time_boot_ms (of ATTITUDE, its quickest stream), s."""
    client.wait_for(lambda: client.latest.get('ATTITUDE'), 5.0, 'ATTITUDE')
    start = len(client.history)
    client.sleep(0.3)
    return max(m.time_boot_ms for _, m in client.history[start:] if m.get_type() == 'ATTITUDE') / 1000.0


def test_the_clock_waits_for_a_stopped_participant_and_goes_on(sim_px4, participant):
    client, clock = sim_px4.client, sim_px4.clock
    lead = clock.board.lead_s
    before_boot, before = boot_s(client), clock.now()
    participant.send_signal(signal.SIGSTOP)
    time.sleep(1.0)                                              # wall seconds, the participant off the CPU
    held = clock.now()
    assert held - before < 0.3 * clock.speed + lead + 0.1, \
        'the clock ran %.2f s (simulated) while a participant was stopped for 1 wall second' % (held - before)
    participant.send_signal(signal.SIGCONT)
    time.sleep(0.5)
    assert clock.now() - held > 0.3 * clock.speed, 'the clock did not go on once the participant came back'
    after_boot = boot_s(client)
    assert after_boot - before_boot < (clock.now() - before) + 0.5, 'the vehicle\'s time_boot_ms ran on its own'
    holds, _, _ = clock.board.holds()
    assert holds >= 1, 'no hold counted: %s' % (clock.board.holds(),)  # the last holder may be another, busy


def test_the_clock_goes_on_without_a_participant_stopped_for_good(sim_px4, participant):
    clock = sim_px4.clock
    participant.send_signal(signal.SIGSTOP)
    before = clock.now()
    time.sleep(clock_board.STALE_WALL_S + 1.5)
    ran = clock.now() - before
    assert ran > 0.8 * clock.speed, 'the clock stayed held by a participant silent for %.1f wall s: it ran %.2f s' % (
        clock_board.STALE_WALL_S + 1.5, ran)
    participant.send_signal(signal.SIGCONT)
