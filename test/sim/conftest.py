"""The simulated PX4 as a real process, and a plain pymavlink client talking to it over UDP.

No ROS: this is how QGroundControl, MAVSDK or a script would see the vehicle. The simulator
process, the client and the fixtures are the package's public test kit
(offboard_py.testing.sim_client, offboard_py.testing.pytest_plugin), so this tier uses them as a
user's package would: each test starts its own simulator instance (its own system id and ports)
on an instance that is free at the time, at OFFBOARD_PY_SPEED, its client on the same simulated
clock.
"""

import os

from offboard_py.testing.pytest_plugin import pytest_runtest_makereport, sim_px4, start_sim  # noqa: F401 (fixtures)


def pytest_collection_modifyitems(config, items):
    """Under ./run test, this tier runs in a network namespace of its own beside catkin's run_tests
    (OFFBOARD_PY_SIM_TIER=elsewhere); catkin's copy of it then runs nothing and says where it runs."""
    if os.environ.get('OFFBOARD_PY_SIM_TIER') == 'elsewhere' and items:
        print('\ntest/sim: the %d tests of this tier run beside this one, in their own network namespace '
              '(./run test; results: pytest-sim.xml, log: .ws/test-sim.log)' % len(items))
        config.hook.pytest_deselected(items=list(items))
        items[:] = []
