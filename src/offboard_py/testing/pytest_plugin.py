"""pytest fixtures that start the simulated PX4 for plain pymavlink tests (no ROS).

Use it from a test module or a top-level conftest.py:

    pytest_plugins = ['offboard_py.testing.pytest_plugin']

or import the fixtures by name into any conftest.py:

    from offboard_py.testing.pytest_plugin import sim_px4, start_sim  # noqa: F401

Fixtures:
  sim_px4    one simulated PX4 with its first HEARTBEAT received: a SimProcess (instance,
             system_id, fcu_port, bridge_port, clock, output) whose `client` is a connected
             offboard_py.testing.sim_client.Client (`client.mav` is its MAVLink codec, `client.write` sends raw bytes)
  start_sim  a factory: start_sim(*sim_px4_args, connect=True) -> (SimProcess, Client or None),
             as many as a test needs, each on its own free instance; connect=False leaves the
             bridge port (SimProcess.url) to a pymavlink connection of the test's own

Each simulator gets an instance whose ports are free (20..37 of offboard_py.testing.ports), runs
at OFFBOARD_PY_SPEED (1 when unset) unless given --speed, must send its first HEARTBEAT within
10 wall seconds (else the test fails with the simulator's output), and is stopped and reaped at
teardown whatever the test did; a test that fails prints each simulator's output.

The session's simulators and clients run on one governed clock (offboard_py.clock_board): this process
governs it from a thread, every simulator and client is a participant, so a simulator or a test starved
of CPU holds the clock instead of missing a simulated deadline. OFFBOARD_PY_CLOCK_BOARD= (empty) leaves
the clock ungoverned (speed x the monotonic clock).
"""

import os

import pytest

from offboard_py import clock_board
from offboard_py.simtime import speed_from_env
from offboard_py.testing.sim_client import start_simulated_px4

_governed = {}


def pytest_configure(config):
    """The session's clock board, governed from a thread of this process, for its simulators and clients."""
    if clock_board.BOARD_ENV in os.environ:
        return  # given (or turned off, empty) by the caller
    clock_board.sweep()  # what killed runs left in /dev/shm
    path = os.path.join(clock_board.BOARD_DIR, 'offboard_py-clock-pytest-%d' % os.getpid())
    board = clock_board.Board(path, speed_from_env(1.0))
    os.environ[clock_board.BOARD_ENV] = path
    _governed.update(board=board, governor=clock_board.GovernorThread(board))


def pytest_unconfigure(config):
    if not _governed:
        return
    _governed['governor'].stop()
    holds, held_s, last = _governed['board'].holds()
    if holds:
        print('\nthe governed clock waited %d times for its slowest participant, %.2f wall seconds in all (the last '
              'for %s)' % (holds, held_s, last))
    try:
        os.unlink(_governed['board'].path)
    except OSError:
        pass
    os.environ.pop(clock_board.BOARD_ENV, None)
    _governed.clear()


@pytest.fixture
def start_sim(request):
    """start_sim(*args, connect=True) -> (SimProcess, Client or None), on a free instance each."""
    started = []

    def start(*args, connect=True):
        sim, client = start_simulated_px4(*args, connect=connect, taken=[s.instance for s in started])
        started.append(sim)
        return sim, client
    yield start
    failed = getattr(request.node, 'rep_call', None) is not None and request.node.rep_call.failed
    for sim in started:
        if sim.client is not None:
            sim.client.close()
        sim.stop()
        if failed:
            print('--- simulated PX4, instance %d (%s) ---\n%s' % (sim.instance, ' '.join(sim.args[3:]), sim.output))


@pytest.fixture
def sim_px4(start_sim):
    """One simulated PX4 with default arguments and a connected Client (sim_px4.client)."""
    sim, _ = start_sim()
    return sim


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Keeps each phase's report on the test item, so that teardown knows whether the test failed."""
    outcome = yield
    report = outcome.get_result()
    setattr(item, 'rep_' + report.when, report)
