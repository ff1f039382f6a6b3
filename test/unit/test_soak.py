"""The soak's rules, offline: the seeded schedule, recovery after a fault, lapses, the RSS rule;
and bench/soak.py's argument checks."""

import pytest

import bench_scripts
from offboard_py.tools import soak_rules as soak

CONN_TIMEOUT_S = 4.0


# --- the schedule ----------------------------------------------------------------------------

def test_same_seed_same_schedule_and_another_seed_another():
    assert soak.make_schedule(17, 30, CONN_TIMEOUT_S) == soak.make_schedule(17, 30, CONN_TIMEOUT_S)
    assert soak.make_schedule(17, 30, CONN_TIMEOUT_S) != soak.make_schedule(18, 30, CONN_TIMEOUT_S)


@pytest.mark.parametrize('seed', [0, 1, 17, 2026])
def test_every_kind_once_before_any_twice_and_parameters_in_range(seed):
    faults = soak.make_schedule(seed, 30, CONN_TIMEOUT_S)
    n = len(soak.KINDS)
    assert len(faults) >= 2 * n, 'a 30-minute soak does each kind at least twice'
    for start in range(0, len(faults) - n + 1, n):
        assert sorted(f.kind for f in faults[start:start + n]) == sorted(soak.KINDS)
    for f in faults:
        if f.kind == soak.CUT_SHORT:
            assert 1.5 <= f.seconds <= CONN_TIMEOUT_S - 1.0, f  # outlasts COM_OF_LOSS_T, under conn/timeout
        elif f.kind == soak.CUT_LONG:
            assert CONN_TIMEOUT_S + 2.0 <= f.seconds <= CONN_TIMEOUT_S + 16.0, f
        elif f.kind == soak.LOSS_BURST:
            assert 0.10 <= f.drop <= 0.30 and 10.0 <= f.seconds <= 60.0, f
        elif f.kind in (soak.JUNK_BRIDGE, soak.JUNK_SIM):
            assert 2000 <= f.datagrams <= 8000 and f.seconds == 0.0, f
        else:
            assert f.seconds == 0.0 and f.datagrams == 0, f
        assert f.what


def test_planned_times_leave_hover_between_faults_and_a_quiet_last_minute():
    faults = soak.make_schedule(17, 30, CONN_TIMEOUT_S)
    assert faults[0].at_s == soak.FIRST_FAULT_S
    assert [f.index for f in faults] == list(range(1, len(faults) + 1))
    for before, after in zip(faults, faults[1:]):
        assert after.at_s - (before.at_s + before.seconds) >= soak.GAP_S[0] - 0.1
    assert faults[-1].at_s <= 30 * 60 - soak.TAIL_S
    assert len(soak.make_schedule(17, 2.5, CONN_TIMEOUT_S)) == 1


@pytest.mark.parametrize('args, reason', [
    (('17', 30, 4.0), 'seed must be a whole number'),
    ((17, 0, 4.0), 'minutes must be above 0'),
    ((17, 30, 2.0), 'conn/timeout must be at least 3'),
])
def test_bad_schedule_inputs_are_named(args, reason):
    with pytest.raises(ValueError, match=reason):
        soak.make_schedule(*args)


# --- recovery --------------------------------------------------------------------------------

def fault(kind=soak.BRIDGE_KILL, seconds=0.0):
    return soak.Fault(1, kind, 100.0, seconds, 0.0, 0, 0, 'a fault')


def test_recovery_counts_only_messages_received_after_the_fault_ended():
    w = soak.FaultWatch(fault(), start_s=100.0)
    w.on_state(100.1, True, 'OFFBOARD', True)   # a killed bridge's last word: stale
    w.on_pose(100.2, 2.0)
    assert w.recovered_s is None, 'the fault has not ended'
    w.end(101.0)
    w.on_pose(101.5, 2.0)                        # a pose, but no state since the end yet
    assert w.recovered_s is None
    w.on_state(102.0, False, '', False)
    w.on_state(104.0, True, 'AUTO.RTL', True)
    w.on_state(108.0, True, 'OFFBOARD', True)
    assert w.recovered_s is None, 'the pose at 2 m came before OFFBOARD: it takes a pose after it'
    w.on_pose(109.0, 1.5)
    assert w.recovered_s is None
    w.on_pose(110.0, 1.81)
    assert w.recovered_s == 110.0 and w.recovered
    assert w.recovery_s == pytest.approx(9.0) and w.outage_s == pytest.approx(10.0)
    w.on_state(111.0, True, 'AUTO.LAND', False)  # after the recovery: not this fault's effect
    assert w.effect() == 'AUTO.RTL, disconnected, lowest z 1.50 m'


def test_recovery_needs_connected_offboard_armed_and_2m_within_0_2():
    assert soak.in_hover(True, 'OFFBOARD', True, 2.2)
    assert soak.in_hover(True, 'OFFBOARD', True, 1.8)
    assert not soak.in_hover(True, 'OFFBOARD', True, 1.79)
    assert not soak.in_hover(True, 'OFFBOARD', False, 2.0)
    assert not soak.in_hover(True, 'AUTO.LOITER', True, 2.0)
    assert not soak.in_hover(False, 'OFFBOARD', True, 2.0)
    assert not soak.in_hover(True, 'OFFBOARD', True, None)


def test_a_fault_that_changes_nothing_recovers_on_the_first_state_after_it():
    w = soak.FaultWatch(fault(soak.LOSS_BURST, 30.0), start_s=100.0)
    for t in range(100, 130):
        w.on_pose(t + 0.5, 2.05)
        w.on_state(t + 0.7, True, 'OFFBOARD', True)
    w.end(130.0)
    w.on_pose(130.5, 2.05)
    assert w.recovered_s is None, 'no state received since the end yet'
    w.on_state(130.7, True, 'OFFBOARD', True)
    w.on_pose(131.0, 2.05)
    assert w.recovered_s == 131.0 and w.recovery_s == pytest.approx(1.0)
    assert w.effect() == 'stayed OFFBOARD, armed, lowest z 2.05 m'


def test_overdue_after_the_bound_and_an_error_is_never_recovered():
    w = soak.FaultWatch(fault(), start_s=100.0, bound_s=90.0)
    assert not w.overdue(500.0), 'not ended: the respawn has its own bound'
    w.end(101.0)
    assert not w.overdue(191.0) and w.overdue(191.1)
    w.error = 'bridge not respawned within 60 s'
    w.on_state(192.0, True, 'OFFBOARD', True)
    w.on_pose(192.1, 2.0)
    assert not w.recovered


def test_monitor_watches_the_start_up_then_records_lapses_only_between_faults():
    m = soak.Monitor()
    m.on_state(10.0, True, 'AUTO.LOITER', False)
    m.on_state(20.0, True, 'OFFBOARD', True)
    m.on_pose(25.0, 1.9)
    assert m.startup.recovered_s == 25.0 and m.current is None
    assert m.hover_held_s(65.0) == pytest.approx(40.0)
    m.on_pose(70.0, 2.45)                        # hover wander is not a lapse
    m.on_pose(71.0, 1.4)
    assert m.lapses == [(71.0, 'z 1.40 m')]
    assert m.hover_held_s(72.0) == 0.0
    m.on_pose(72.0, 2.0)
    assert m.hover_held_s(80.0) == pytest.approx(8.0)
    w = m.begin(fault(), 100.0)
    m.on_state(101.0, False, '', False)          # the fault's doing, not a lapse
    w.end(102.0)
    m.on_state(103.0, True, 'OFFBOARD', True)
    assert m.hover_held_s(103.0) == 0.0
    m.on_pose(104.0, 2.0)
    assert w.recovered_s == 104.0 and len(m.lapses) == 1
    m.on_state(110.0, True, 'AUTO.RTL', True)
    assert m.lapses[-1] == (110.0, 'mode AUTO.RTL')
    assert m.watches == [w]


# --- the memory rule -------------------------------------------------------------------------

def samples(role, pid, start, values, period=5.0):
    return [(start + i * period, role, pid, v) for i, v in enumerate(values)]


def test_rss_growth_after_each_process_first_minute_respawns_apart():
    data = (samples('node', 10, 10.0, [30.0, 45.0, 49.0] + [49.0] * 10 + [50.9])      # start-up growth is free
            + samples('bridge', 11, 10.0, [56.0] * 13 + [None])                         # a None: gone, skipped
            + samples('bridge', 12, 200.0, [40.0] + [56.0] * 12 + [58.1])               # respawned: its own minute
            + samples('sim', 13, 10.0, [25.0] * 5))                                     # killed within a minute
    rows = {(r['role'], r['pid']): r for r in soak.rss_growth(data)}
    node = rows[('node', 10)]
    assert node['baseline_s'] == 70.0 and node['baseline_mb'] == 49.0
    assert node['growth_mb'] == pytest.approx(1.9) and node['ok'] and node['judged']
    assert rows[('bridge', 11)]['growth_mb'] == 0.0 and rows[('bridge', 11)]['last_s'] == 70.0
    respawned = rows[('bridge', 12)]
    assert respawned['baseline_mb'] == 56.0 and respawned['growth_mb'] == pytest.approx(2.1)
    assert not respawned['ok']
    assert not rows[('sim', 13)]['judged'] and rows[('sim', 13)]['ok']
    assert [r['pid'] for r in soak.rss_growth(data)] == [10, 11, 13, 12], 'in order of appearance'


def test_rss_limit_is_inclusive_at_2_mb():
    rows = soak.rss_growth(samples('node', 1, 0.0, [50.0] * 13 + [52.0]))
    assert rows[0]['growth_mb'] == 2.0 and rows[0]['ok']


# --- the verdict and the tables -----------------------------------------------------------------

def test_verdict_names_every_reason_and_passes_when_there_is_none():
    good = soak.FaultWatch(fault(), 100.0)
    good.end(101.0)
    good.on_state(102.0, True, 'OFFBOARD', True)
    good.on_pose(103.0, 2.0)
    bad = soak.FaultWatch(soak.Fault(2, soak.CUT_LONG, 200.0, 12.0, 0.0, 0, 0, 'link cut both ways for 12.0 s'),
                          200.0)
    bad.end(212.0)
    rows = soak.rss_growth(samples('node', 7, 0.0, [50.0] * 13 + [53.0]))
    assert soak.verdict([good], soak.rss_growth(samples('node', 7, 0.0, [50.0] * 14)), []) == []
    reasons = soak.verdict([good, bad], rows, [(300.0, 'mode AUTO.RTL')], stopped='interrupted at 301.0 s')
    assert reasons[0] == ('fault 2 (link cut both ways for 12.0 s) not recovered: not back in hover within 90 s '
                          'of its end')
    assert reasons[1].startswith('node (pid 7) RSS grew 3.0 MB after its first minute (50.0 -> 53.0 MB')
    assert reasons[2] == 'hover lost 1 time(s) with no fault under way (first at 300.0 s: mode AUTO.RTL)'
    assert reasons[3] == 'interrupted at 301.0 s'
    table = soak.fault_table([good, bad])
    assert table[2].startswith('| 1 | a fault | 100.0 | 101.0 |') and table[2].endswith('| 2.0 | 3.0 | yes |')
    assert table[3].endswith('| - | - | **NO** |')
    assert '| node | 7 | 0-65 | 50.0 | 53.0 | +3.0 | **NO** |' in soak.rss_table(rows)


# --- bench/soak.py's arguments -------------------------------------------------------------------

@pytest.fixture(scope='module')
def bench_soak():
    return bench_scripts.load('soak')


@pytest.mark.parametrize('argv, message', [
    (['--minutes', 'ten'], "--minutes must be a number of simulated minutes, got 'ten'"),
    (['--minutes', '2'], '--minutes must be between 2.5'),
    (['--minutes', '2000'], '--minutes must be between 2.5'),
    (['--speed', '0'], '--speed must be a finite number > 0'),
    (['--seed', '1.5'], "--seed must be a whole number, got '1.5'"),
    (['--instance', '40'], '--instance must be a whole number 0..39'),
    (['--out', 'out/soak.txt'], '--out must name a .json file'),
    (['12', '--minutes', '10'], 'give the minutes once: MINUTES (12) or --minutes (10)'),
])
def test_bad_arguments_are_refused_naming_them(bench_soak, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_:
        bench_soak.parse_args(argv)
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err


def test_defaults_are_the_documented_ones(bench_soak, tmp_path):
    args = bench_soak.parse_args(['--out', str(tmp_path / 'x.json')])
    assert (args.minutes, args.speed, args.seed) == (30.0, 5.0, 17)
    assert args.log == str(tmp_path / 'soak-launch.log')
    assert bench_soak.parse_args(['12']).minutes == bench_soak.parse_args(['--minutes', '12']).minutes == 12.0


def test_junk_is_as_many_datagrams_as_asked(bench_soak):
    import random
    stack = bench_soak.soak_stack  # bench/soak_stack.py, as bench/soak.py loads it
    assert len(list(stack.junk_for_sim(random.Random(1), 500, 39))) == 500
    assert len(list(stack.junk_for_bridge(random.Random(1), 500, 39))) == 500
