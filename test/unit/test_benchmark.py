"""bench/benchmark.py's pure parts, offline: which process of a launched stack is which (also with real
mavros as the ROS side, --bridge mavros), and --bridge mavros refused where there is no mavros or with the
simulator's packed datagrams, which real mavros cannot read."""

import sys

import pytest

import bench_scripts


@pytest.fixture(scope='module')
def benchmark():
    return bench_scripts.load('benchmark')


@pytest.mark.parametrize('cmdline, role', [
    (b'/usr/bin/python3 /ws/src/offboard_py/scripts/sim_px4.py -i 0 --vehicles 32 --spawn 0,0 __name:=sim_px4', 'sim'),
    (b'/usr/bin/python3 /ws/devel/lib/offboard_py/mavros_bridge.py __name:=mavros __log:=/r/l.log', 'bridge'),
    (b'/opt/mavros_ws/devel/lib/mavros/mavros_node __name:=mavros __log:=/r/uav3-mavros-1.log', 'bridge'),
    (b'/usr/bin/python3 /ws/devel/lib/offboard_py/offb_node.py __name:=offb_node', 'node'),
    (b'/usr/bin/python3 /usr/bin/roslaunch offboard_py multi_uav.launch n:=32 bridge:=mavros', None),
    (b'/usr/bin/python3 /usr/bin/rosmaster --core -p 11311', None),
])
def test_each_process_of_the_stack_is_told_apart_by_its_command_line(benchmark, cmdline, role):
    assert benchmark.role_of(cmdline) == role


@pytest.mark.parametrize('cmdline, served', [
    (b'/usr/bin/python3 /ws/src/offboard_py/scripts/sim_px4.py -i 16 --vehicles 16 --spawn 0,48 --speed 1 '
     b'--setpoint-log /tmp/b __name:=sim_px4_16', range(16, 32)),
    (b'/usr/bin/python3 /ws/src/offboard_py/scripts/sim_px4.py -i 0 --vehicles 3 --spawn 0,0 __name:=sim_px4', range(3)),
    (b'/usr/bin/python3 /ws/src/offboard_py/scripts/sim_px4.py --instance 5 __name:=sim_px4', range(5, 6)),
])
def test_a_shared_simulator_is_counted_for_the_vehicles_it_serves(benchmark, cmdline, served):
    """multi_uav.launch sim_process:=one starts a simulator process for each vehicles_per_sim vehicles: each
    process's CPU is shared among its own vehicles, not among the whole fleet."""
    assert benchmark.vehicles_served(cmdline) == served


def test_bridge_mavros_without_mavros_is_refused_naming_what_was_looked_for(benchmark, tmp_path, monkeypatch,
                                                                             capsys):
    monkeypatch.setenv('ROS_PACKAGE_PATH', str(tmp_path))  # a package path with no mavros on it
    monkeypatch.setenv('ROS_HOME', str(tmp_path))
    monkeypatch.setattr(sys, 'argv', ['benchmark.py', '--bridge', 'mavros', '--duration', '5'])
    with pytest.raises(SystemExit) as exit_:
        benchmark.main()
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert '--bridge mavros needs real mavros' in err and '`rospack find mavros` finds no package' in err


def test_an_unknown_ros_side_is_refused_naming_the_choices(benchmark, monkeypatch, capsys):
    monkeypatch.setattr(sys, 'argv', ['benchmark.py', '--bridge', 'mavros2'])
    with pytest.raises(SystemExit) as exit_:
        benchmark.main()
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "--bridge: invalid choice: 'mavros2'" in err and "'ours'" in err and "'mavros'" in err


def test_a_shared_simulator_of_no_vehicles_is_refused(benchmark, monkeypatch, capsys):
    monkeypatch.setattr(sys, 'argv', ['benchmark.py', '--sim-process', 'one', '--vehicles-per-sim', '0'])
    with pytest.raises(SystemExit) as exit_:
        benchmark.main()
    assert exit_.value.code == 2
    assert '--vehicles-per-sim must be 1 or more, got 0' in capsys.readouterr().err


def test_bridge_mavros_with_packed_datagrams_is_refused(benchmark, monkeypatch, capsys):
    monkeypatch.setattr(sys, 'argv', ['benchmark.py', '--bridge', 'mavros', '--pack-datagrams'])
    with pytest.raises(SystemExit) as exit_:
        benchmark.main()
    assert exit_.value.code == 2
    assert 'real mavros reads at most 296 bytes of a datagram' in capsys.readouterr().err


def test_steps_skipped_counts_the_stalls_inside_the_window_only(benchmark, tmp_path):
    """A row whose simulated PX4 fell behind its clock and skipped steps in the window does not hold the
    bar: the count comes from sim_px4.py's stalls-N.txt (time ns, ms behind, steps)."""
    (tmp_path / 'stalls-3.txt').write_text('100 300.0 30\n200 810.5 81\n300 260.0 26\n')
    assert benchmark.steps_skipped(str(tmp_path), 3, 150, 300) == 81 + 26
    assert benchmark.steps_skipped(str(tmp_path), 3, 301, 400) == 0
    (tmp_path / 'stalls-4.txt').write_text('')
    assert benchmark.steps_skipped(str(tmp_path), 4, 0, 400) == 0
    assert benchmark.steps_skipped(str(tmp_path), 5, 0, 400) is None, 'no file: not known, not zero'
