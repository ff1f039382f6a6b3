"""The shared test helpers that carry logic: the port allocator and the phase watcher, offline."""

import socket
from types import SimpleNamespace

import pytest

from offboard_py.tools.hover_phases import PhaseWatcher
from offboard_py.testing import ports


def test_ports_follow_px4_sitl_and_never_overlap():
    assert (ports.system_id(0), ports.fcu_port(0), ports.bridge_port(0)) == (1, 14580, 14540)
    assert (ports.system_id(7), ports.fcu_port(7), ports.bridge_port(7)) == (8, 14587, 14547)
    every = [p for n in range(ports.MAX_INSTANCE + 1)
             for p in [ports.fcu_port(n), ports.bridge_port(n)] + [ports.extra_port(n, k) for k in range(10)]]
    assert len(every) == len(set(every)), 'two instances share a port'
    for bad in (-1, ports.MAX_INSTANCE + 1):
        with pytest.raises(ValueError, match='instance'):
            ports.fcu_port(bad)
    with pytest.raises(ValueError, match='extra port'):
        ports.extra_port(0, 10)


def test_free_instances_skip_taken_and_busy_ones():
    first = ports.free_instances(2)
    assert len(first) == 2 and first[1] == first[0] + 1 and set(first) <= set(ports.PYTEST_INSTANCES)
    busy = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    busy.bind(('127.0.0.1', ports.fcu_port(first[0])))
    try:
        assert first[0] not in ports.free_instances(1, candidates=first)
    finally:
        busy.close()
    assert ports.free_instances(1, taken=first)[0] not in first
    with pytest.raises(RuntimeError, match='no 3 free'):
        ports.free_instances(3, candidates=[20, 21])


def state(connected=True, mode='AUTO.LOITER', armed=False):
    return SimpleNamespace(connected=connected, mode=mode, armed=armed)


def pose(z):
    return SimpleNamespace(pose=SimpleNamespace(position=SimpleNamespace(z=z)))


def test_phase_watcher_first_times_and_repeats():
    now = [0.0]
    w = PhaseWatcher(t0=0.0, clock=lambda: now[0])
    w.on_pose(pose(2.0))
    assert 'hover' not in w.first, 'hover counts only after arming'
    for t, msg in ((1.0, state()), (2.0, state(mode='OFFBOARD')), (3.0, state(mode='OFFBOARD', armed=True))):
        now[0] = t
        w.on_state(msg)
    now[0] = 4.0
    w.on_pose(pose(1.5))
    now[0] = 5.0
    w.on_pose(pose(1.95))
    now[0] = 6.0
    w.on_state(state(mode='AUTO.RTL', armed=True))
    now[0] = 7.0
    w.on_state(state(mode='OFFBOARD', armed=True))
    assert w.first == {'connected': 1.0, 'offboard': 2.0, 'armed': 3.0, 'hover': 5.0}
    assert [e for e in w.events if e[1] == 'offboard'] == [(2.0, 'offboard'), (7.0, 'offboard')]
