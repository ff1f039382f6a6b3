"""Simulated time: the speed factor, the shared clock formula, and /clock's tick grid."""

import math

import pytest

from offboard_py.clock_node import ClockTicks
from offboard_py.simtime import SimClock, SpeedError, parse_speed, speed_from_env


@pytest.mark.parametrize('text, speed', [('5', 5.0), (2, 2.0), ('0.5', 0.5), ('1', 1.0), (' 10 ', 10.0)])
def test_speed_parses(text, speed):
    assert parse_speed(text) == speed


@pytest.mark.parametrize('text', ['0', '-1', 'nan', 'inf', 'fast', '', None])
def test_bad_speed_is_refused_naming_it(text):
    with pytest.raises(SpeedError) as err:
        parse_speed(text, '--speed')
    assert '--speed' in str(err.value) and repr(text) in str(err.value)


def test_speed_from_env():
    assert speed_from_env(1.0, {}) == 1.0
    assert speed_from_env(1.0, {'OFFBOARD_PY_SPEED': ''}) == 1.0
    assert speed_from_env(1.0, {'OFFBOARD_PY_SPEED': '5'}) == 5.0
    with pytest.raises(SpeedError, match='OFFBOARD_PY_SPEED'):
        speed_from_env(1.0, {'OFFBOARD_PY_SPEED': 'x'})


def test_every_process_computes_the_same_simulated_second():
    wall = [1000.0]
    slept = []
    a = SimClock(5, monotonic=lambda: wall[0], sleep=slept.append)
    b = SimClock('5', monotonic=lambda: wall[0])
    assert a.now() == b() == 5000.0
    wall[0] += 2.0
    assert a.now() - 5000.0 == pytest.approx(10.0)  # 2 wall seconds are 10 simulated
    a.sleep(1.0)
    assert slept == [pytest.approx(0.2)]
    assert a.wall_s(1.0) == pytest.approx(0.2) and a.sim_s(0.2) == pytest.approx(1.0)
    assert SimClock(1).real_time and not a.real_time


def test_clock_ticks_on_a_grid_never_backwards_and_say_how_late():
    ticks = ClockTicks(0.01, 100.0)
    assert ticks.due(100.005) is None
    tick_ns, late = ticks.due(100.0101)
    assert tick_ns == 100010000000 and late == pytest.approx(0.0001, abs=1e-6)
    assert ticks.due(100.0150) is None
    # a stall of 0.5 s: one tick, the latest grid point, and the lag reported
    tick_ns, late = ticks.due(100.5203)
    assert tick_ns == 100520000000 and late == pytest.approx(0.5003, abs=1e-6)
    assert ticks.lag_max_s == pytest.approx(0.5003, abs=1e-6)
    assert ticks.due(100.5204) is None


def test_clock_ticks_are_exact_nanoseconds_over_a_long_run():
    ticks = ClockTicks(0.01, 0.0)
    last = 0
    now = 0.0
    for step in range(1, 20000):
        now = step * 0.01 + 1e-7
        due = ticks.due(now)
        assert due is not None
        assert due[0] - last == 10000000 and due[0] % 10000000 == 0
        last = due[0]
    assert math.isclose(last / 1e9, now, abs_tol=0.01)
