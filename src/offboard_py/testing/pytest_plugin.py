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
"""

import pytest

from offboard_py.testing.sim_client import start_simulated_px4


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
