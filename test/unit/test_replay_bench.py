"""bench/replay_bench.py's --compare plumbing, offline: finding real mavros with rospack in a setup
file's environment, finding the measured process under a launcher, refusing --compare
without mavros, and the side-by-side table."""

import os
import subprocess
import time

import pytest

import bench_scripts
from offboard_py import stack


@pytest.fixture(scope='module')
def replay_bench():
    return bench_scripts.load('replay_bench')


def _package(root, name):
    os.makedirs(os.path.join(root, name))
    with open(os.path.join(root, name, 'package.xml'), 'w') as out:
        out.write('<?xml version="1.0"?>\n<package format="2"><name>%s</name><version>1.21.0</version>'
                  '<description>d</description><maintainer email="m@example.com">m</maintainer>'
                  '<license>BSD</license><buildtool_depend>catkin</buildtool_depend></package>\n' % name)
    return os.path.join(root, name)


def _setup(path, package_path):
    with open(path, 'w') as out:
        out.write('export ROS_PACKAGE_PATH=%s\nexport ROS_HOME=%s\n' % (package_path, os.path.dirname(path)))
    return str(path)


def test_mavros_is_found_in_the_environment_a_setup_file_makes(tmp_path):
    where = _package(str(tmp_path / 'ws'), 'mavros')
    assert stack.rospack_find('mavros', _setup(tmp_path / 'setup.bash', str(tmp_path / 'ws'))) == where


def test_no_mavros_on_the_path_is_none(tmp_path):
    _package(str(tmp_path / 'ws'), 'mavros_msgs')  # a neighbour's name is not mavros
    assert stack.rospack_find('mavros', _setup(tmp_path / 'setup.bash', str(tmp_path / 'ws'))) is None


def test_compare_without_mavros_is_refused_naming_what_was_looked_for(replay_bench, tmp_path, capsys):
    setup = _setup(tmp_path / 'setup.bash', str(tmp_path))
    with pytest.raises(SystemExit) as exit_:
        replay_bench.main(['--compare', '--mavros-setup', setup, '--duration', '5'])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert '--compare needs real mavros' in err and '`rospack find mavros` finds no package' in err and setup in err
    assert '2.08-2.33 %' in err  # what stands in for it: the recorded figures


@pytest.mark.parametrize('argv, message', [
    (['--mavros-setup', '/nonexistent/setup.bash'], '--mavros-setup goes with --compare'),
    (['--compare', '--mavros-setup', '/nonexistent/setup.bash'], '--mavros-setup /nonexistent/setup.bash: no such file'),
    (['--runs', '0'], '--runs must be 1 or more'),
    (['--duration', '0.5'], 'the durations above 1 s'),
])
def test_bad_command_lines_are_refused_by_name(replay_bench, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_:
        replay_bench.main(argv)
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err


def test_the_measured_process_is_found_by_name_under_its_launcher(replay_bench):
    # a launcher (sh) whose grandchild is the node, as roslaunch starts mavros_node
    launcher = subprocess.Popen(['sh', '-c', 'sh -c "sleep 30; true"; true'])
    try:
        deadline = time.monotonic() + 10.0
        pid = None
        while pid is None and time.monotonic() < deadline:
            pid = replay_bench.process_named(launcher.pid, 'sleep')
            time.sleep(0.05)
        assert pid is not None and pid != launcher.pid
        assert open('/proc/%d/comm' % pid).read().strip() == 'sleep'
        assert replay_bench.process_named(launcher.pid, 'mavros_node') is None
    finally:
        launcher.kill()
        launcher.wait()
        subprocess.run(['pkill', '-P', str(launcher.pid)], check=False)


def test_a_launcher_that_exits_without_the_node_is_an_error_naming_it(replay_bench):
    launcher = subprocess.Popen(['true'])
    launcher.wait()
    with pytest.raises(RuntimeError, match='no mavros_node under roslaunch mavros px4.launch .*exited with 0'):
        replay_bench.measured_pid('mavros', launcher, timeout_s=5.0)


def _run(side, cpu, wake, p99, topics):
    return {'side': side, 'cpu_pct': {'bridge': cpu, 'node': 0.7}, 'wakeups_per_s': {'bridge': wake},
            'bridge_cpu_pct_all_topics_subscribed': cpu * 2, 'latency_ms': {'p99': p99},
            'setpoints_at_fcu_hz': 20.0, 'replay': {'timesync answer ms p99': 1.5},
            'topics': {t: {'rate_hz': hz} for t, hz in topics.items()}}


def test_the_side_by_side_table_sets_medians_against_each_other_on_the_topics_both_publish(replay_bench):
    runs = [_run('bridge', 3.0, 250, 1.2, {'/mavros/state': 1.0, '/mavros/imu/data': 50.0}),
            _run('mavros', 2.0, 180, 0.9, {'/mavros/state': 1.0, '/mavros/imu/data': 49.0, '/mavros/only': 5.0}),
            _run('bridge', 4.0, 260, 1.3, {'/mavros/state': 1.0, '/mavros/imu/data': 50.0}),
            _run('mavros', 2.4, 190, 1.1, {'/mavros/state': 1.0, '/mavros/imu/data': 48.0, '/mavros/only': 5.0})]
    table = replay_bench.compare_table(runs)
    rows = {line.split(' | ')[0].lstrip('| '): line for line in table.splitlines()}
    assert rows['CPU, % of one core'] == '| CPU, % of one core | 3.00 / 4.00 | 2.00 / 2.40 | 1.59 |'  # 3.5 / 2.2
    assert rows['wake-ups per s'].endswith('| 250 / 260 | 180 / 190 | 1.38 |')  # 255 / 185
    assert rows['/mavros/imu/data'] == '| /mavros/imu/data | 50.0 / 50.0 | 49.0 / 48.0 |'
    assert '/mavros/only' not in rows  # only mavros publishes it: nothing to set beside it
