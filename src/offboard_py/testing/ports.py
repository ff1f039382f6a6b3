"""Instance numbers and UDP ports for tests, so that runs do not clash.

A test vehicle is PX4 SITL instance N (0..39), with PX4 SITL's system id and ports: the formula is
offboard_py.sitl_ports's alone; this module checks the instance range, hands out free instances and
gives each instance a block of extra ports (15000 + 10 N + k, k = 0..9: relays, a GCS, a fake FCU,
control ports).
N stays below 40 so that the FCU and bridge ranges never overlap.

Who uses which N: INSTANCES below, the one table (docs/testing.md shows it, test/unit/test_instances.py holds
CMakeLists.txt, the .test files and the example packages to it).
"""

import socket

from offboard_py import sitl_ports
from offboard_py.sitl_ports import BRIDGE_PORT_BASE, FCU_PORT_BASE

EXTRA_PORT_BASE = 15000
EXTRA_PORTS_PER_INSTANCE = 10
MAX_INSTANCE = 39
PYTEST_INSTANCES = range(20, 38)

# (first, last, who): every instance offboard_py's own runs and examples take. A range may be shared only where
# the users never run at once on one loopback: under ./run test the pytest tiers and the examples run in network
# namespaces of their own; catkin alone runs the rostests one after another. In a workspace of yours
# (`catkin_make run_tests` without -DOFFBOARD_PY_TESTS=ON) none of offboard_py's own tests run: every N is yours
# but those another stack on the host holds (PX4 SITL instance N, or a second run of your tests).
INSTANCES = (
    (0, 19, "offboard_py's rostest scenarios, each its own N from CMakeLists.txt (instance:=N); two_vehicles 0 "
            "and 1; 15 only for conversation, whose bridge binds its extra port: 15's bridge port 14555 is mavros's "
            "default ground-station port"),
    (19, 28, "offboard_py's rostest scenarios past 19: fleet_shared_sims 19-21, the failsafes 22-27 (and 16), figure 28"),
    (20, 37, "offboard_py's pytest tiers (test/sim, test/meta), free_instances() per test"),
    (30, 32, "the example packages' tests (examples/*/CMakeLists.txt): hover 30, failsafe 31, square 32"),
    (38, 39, "a .test file run by hand without instance:=N (its default; respect_pilot takes both); the soak 38"),
)


def _check(instance):
    if not 0 <= instance <= MAX_INSTANCE:
        raise ValueError('instance %r: expected 0..%d' % (instance, MAX_INSTANCE))
    return instance


def system_id(instance):
    return sitl_ports.system_id(_check(instance))


def fcu_port(instance):
    """UDP port the simulated PX4 of this instance binds."""
    return sitl_ports.fcu_port(_check(instance))


def bridge_port(instance):
    """UDP port the bridge (or a ground station) of this instance binds."""
    return sitl_ports.bridge_port(_check(instance))


def extra_port(instance, k):
    """The k-th (0..9) port of this instance's own block, for relays and fake ends."""
    if not 0 <= k < EXTRA_PORTS_PER_INSTANCE:
        raise ValueError('extra port %r: expected 0..%d' % (k, EXTRA_PORTS_PER_INSTANCE - 1))
    return EXTRA_PORT_BASE + EXTRA_PORTS_PER_INSTANCE * _check(instance) + k


def _udp_free(port, host='127.0.0.1'):
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
        return True
    except OSError:
        return False
    finally:
        sock.close()


def instance_free(instance):
    """True when nothing on this host holds the FCU or the bridge port of the instance."""
    return _udp_free(fcu_port(instance)) and _udp_free(bridge_port(instance))


def free_instances(count, candidates=PYTEST_INSTANCES, taken=()):
    """`count` consecutive instances from candidates, not in taken, whose ports are free now.

    Raises RuntimeError naming the range when there are none.
    """
    candidates = list(candidates)
    for i, first in enumerate(candidates):
        block = candidates[i:i + count]
        if len(block) == count and block == list(range(first, first + count)) \
                and not set(block) & set(taken) and all(instance_free(n) for n in block):
            return block
    raise RuntimeError('no %d free consecutive instances in %d..%d (ports %d.., %d..)'
                       % (count, candidates[0], candidates[-1], FCU_PORT_BASE, BRIDGE_PORT_BASE))


def free_tcp_port(host='127.0.0.1'):
    """A TCP port the kernel says is free now (for a private ROS master)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind((host, 0))
        return sock.getsockname()[1]
    finally:
        sock.close()
