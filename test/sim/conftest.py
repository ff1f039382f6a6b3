"""The simulated PX4 as a real process, and a plain pymavlink client talking to it over UDP.

No ROS: this is how QGroundControl, MAVSDK or a script would see the vehicle. The simulator
process, the client and the fixtures are the package's public test kit
(offboard_py.testing.sim_client, offboard_py.testing.pytest_plugin), so this tier uses them as a
user's package would: each test starts its own simulator instance (its own system id and ports)
on an instance that is free at the time, at OFFBOARD_PY_SPEED, its client on the same simulated
clock: the session's governed clock, which waits for a simulator or a client starved of CPU.
"""

from offboard_py.testing.tiers import run_elsewhere, run_shard
from offboard_py.testing.pytest_plugin import (  # noqa: F401 (fixtures, and the session's governed clock)
    pytest_configure, pytest_runtest_makereport, pytest_unconfigure, sim_px4, start_sim)


def pytest_collection_modifyitems(config, items):
    """Under ./run test this tier runs beside the scenarios, in shards side by side (offboard_py.testing.tiers)."""
    run_elsewhere('sim', config, items, 'test-sim-*.log')
    run_shard(config, items)
