"""Choosing the stack (fcu:=sim|px4_sih, bridge:=ours|mavros) and finding the real parts a user built.

The PX4 build that px4_sih looks for is a folder layout (`build/px4_sitl_default/bin/px4`, `etc/`);
these tests lay one out in a temporary folder to check what is found and what each missing piece
is called, without running PX4 (the cross-stack tier runs a real one where it is installed).
"""

import os
import stat

import pytest

from offboard_py import px4_sih, stack


def px4_tree(root, airframe='10040_sihsim_quadx', executable=True):
    build = root / 'build' / 'px4_sitl_default'
    (build / 'bin').mkdir(parents=True)
    binary = build / 'bin' / 'px4'
    binary.write_text('#!/bin/sh\n')
    if executable:
        binary.chmod(binary.stat().st_mode | stat.S_IXUSR)
    airframes = build / 'etc' / 'init.d-posix' / 'airframes'
    airframes.mkdir(parents=True)
    if airframe:
        (airframes / airframe).write_text('')
    return root


def test_a_built_tree_is_found_with_its_binary_and_etc(tmp_path):
    binary, etc = px4_sih.find_build(str(px4_tree(tmp_path)))
    assert binary == str(tmp_path / 'build' / 'px4_sitl_default' / 'bin' / 'px4')
    assert etc == str(tmp_path / 'build' / 'px4_sitl_default' / 'etc')


@pytest.mark.parametrize('layout, says', [
    (None, 'neither is set'),
    ('missing', 'no such folder'),
    ('unbuilt', 'run `make px4_sitl_default` there'),
    ('not executable', 'bin/px4 not found'),
    ('no sih', 'no SIH quadrotor airframe'),
])
def test_each_missing_piece_is_named(tmp_path, layout, says):
    if layout is None:
        px4_dir = ''
    elif layout == 'missing':
        px4_dir = str(tmp_path / 'nowhere')
    elif layout == 'unbuilt':
        px4_dir = str(tmp_path)
    elif layout == 'not executable':
        px4_dir = str(px4_tree(tmp_path, executable=False))
    else:
        px4_dir = str(px4_tree(tmp_path, airframe='4001_gz_x500'))
    with pytest.raises(px4_sih.MissingPx4) as err:
        px4_sih.find_build(px4_dir)
    assert says in str(err.value)


def test_px4_starts_headless_as_the_sih_quadrotor_at_the_speed():
    env = px4_sih.environment(5.0, base={'PATH': '/bin'})
    assert (env['PX4_SYS_AUTOSTART'], env['PX4_SIM_MODEL'], env['HEADLESS']) == ('10040', 'sihsim_quadx', '1')
    assert env['PX4_SIM_SPEED_FACTOR'] == '5' and env['PATH'] == '/bin'
    assert 'PX4_SIM_SPEED_FACTOR' not in px4_sih.environment(1.0, base={})


def test_each_instance_gets_a_fresh_working_folder(tmp_path):
    first = px4_sih.fresh_work_dir(str(tmp_path), 3)
    with open(os.path.join(first, 'parameters.bson'), 'w') as f:
        f.write('old')
    again = px4_sih.fresh_work_dir(str(tmp_path), 3)
    assert again == first and os.listdir(again) == [], 'parameters of an earlier run are gone'


def test_px4_sih_exits_1_naming_what_is_missing(capsys):
    assert px4_sih.main(['-i', '0', '--px4-dir', '/nonexistent/px4']) == 1
    assert 'px4_dir /nonexistent/px4: no such folder' in capsys.readouterr().err
    assert px4_sih.main(['-i', '-1']) == 2


def test_stack_choices_and_their_errors(capsys):
    assert stack.choice_errors('sim', 'ours') == [] and stack.choice_errors('px4_sih', 'mavros') == []
    assert stack.main(['fcu:=gazebo', 'bridge:=ours', '__name:=stack_check']) == 1
    err = capsys.readouterr().err
    assert 'fcu:=gazebo is not a flight controller' in err and 'fcu:=px4_sih' in err
    assert stack.main(['bridge:=mavros2']) == 1
    assert 'bridge:=mavros2 is not a ROS side' in capsys.readouterr().err
    assert stack.choice_errors('sim', 'ours', 'one') == []
    assert stack.main(['sim_process:=two']) == 1
    assert 'sim_process:=two is not a way to run the simulated vehicles' in capsys.readouterr().err
    assert stack.choice_errors('sim', 'ours', 'one', '8') == []
    for bad in ('0', 'abc', '-2', '1.5', ''):
        assert stack.main(['sim_process:=one', 'vehicles_per_sim:=%s' % bad]) == 1
        assert 'vehicles_per_sim:=%s is not a number of vehicles' % bad in capsys.readouterr().err
    assert stack.describe('px4_sih', 'ours') == 'our mavros-compatible bridge + real PX4 SITL (SIH quadrotor)'


def test_real_parts_are_found_from_the_environment_or_the_config_file(tmp_path):
    tree = px4_tree(tmp_path / 'px4')
    config = tmp_path / 'real-stack.conf'
    config.write_text('# where my PX4 is\nPX4_DIR=%s\n' % tree)
    found = stack.find_real_parts(env={}, config_path=str(config), find_package=lambda name: '/opt/mavros')
    assert (found['px4_dir'], found['mavros'], found['why']) == (str(tree), '/opt/mavros', [])
    none = stack.find_real_parts(env={}, config_path=str(tmp_path / 'absent.conf'), find_package=lambda name: None)
    assert none['px4_dir'] is None and none['mavros'] is None
    assert [line.split(':')[0] for line in none['why']] == ['no real PX4', 'no real mavros']
    config.write_text('PX4_DIR\n')
    with pytest.raises(ValueError, match='expected NAME=value'):
        stack.find_real_parts(env={}, config_path=str(config), find_package=lambda name: None)


def test_cross_stack_plan_runs_what_is_installed_and_says_why_not_the_rest():
    from offboard_py.testing import cross_stack
    px4_only = {'px4_dir': '/opt/PX4-Autopilot', 'mavros': None, 'why': ['no real mavros: ...']}
    rows = {(s, c.name): reason for s, c, reason in cross_stack.plan(px4_only)}
    assert rows['takeoff', 'bridge+px4'] is None and rows['offboard_loss', 'bridge+px4'] is None
    assert rows['takeoff', 'mavros+sim'] == rows['takeoff', 'mavros+px4'] == 'its real parts are not installed here'
    assert 'process name' in rows['restarts', 'bridge+px4'], 'a fault only ours can take is skipped with its reason'
    # the example packages' tests fly as a user flies them on real PX4, every column whose parts are there
    assert rows['example:my_velocity_square/square', 'bridge+px4'] is None
    assert rows['example:my_offboard_check/failsafe', 'mavros+px4'] == 'its real parts are not installed here'
    everything = {'px4_dir': '/opt/PX4-Autopilot', 'mavros': '/opt/ros/noetic/share/mavros', 'why': []}
    assert [c.name for c in cross_stack.columns_found(everything)] == ['bridge+px4', 'mavros+sim', 'mavros+px4']
    assert cross_stack.columns_found({'px4_dir': None, 'mavros': None, 'why': []}) == []


def test_cross_stack_scenarios_are_the_registered_rostests_and_take_the_stack():
    """Each scenario the tier flies is a .test in test/rostest, at the instance CMakeLists.txt registers it
    with (so it never shares ports with another), and passes fcu:=/bridge:=/px4_dir: on to sim_vehicle.launch."""
    import re
    from offboard_py.testing import cross_stack
    repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
    with open(os.path.join(repo, 'CMakeLists.txt')) as f:
        registered = {name: int(n) for name, n in re.findall(r'\b(\w+):(\d+)\b', f.read())}
    for scenario, (test_file, instance, skips) in cross_stack.SCENARIOS.items():
        with open(os.path.join(repo, 'test', 'rostest', test_file)) as f:
            text = f.read()
        assert registered.get(test_file[:-len('.test')]) == instance, (scenario, test_file, instance)
        if cross_stack.ALL not in skips:
            for arg in ('fcu', 'bridge', 'px4_dir'):
                assert '<arg name="%s" value="$(arg %s)"/>' % (arg, arg) in text, (test_file, arg)


def test_cross_stack_without_real_parts_is_one_line(capsys, tmp_path, monkeypatch):
    from offboard_py.testing import cross_stack
    monkeypatch.setenv('PX4_DIR', '')
    monkeypatch.setattr(cross_stack.stack, 'rospack_find', lambda name: None)
    assert cross_stack.main(['--results', str(tmp_path)]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith('cross-stack tier: skipped: no real PX4'), out


def test_junit_outcome_reads_failures_and_errors(tmp_path):
    from offboard_py.testing import cross_stack
    ok, bad = tmp_path / 'ok.xml', tmp_path / 'bad.xml'
    ok.write_text('<testsuite tests="1" failures="0" errors="0"><testcase name="t"/></testsuite>')
    bad.write_text('<testsuites><testsuite tests="2" failures="0" errors="1"/></testsuites>')
    assert cross_stack.junit_outcome(str(ok)) == 'passed'
    assert cross_stack.junit_outcome(str(bad)) == 'failed'
    assert cross_stack.junit_outcome(str(tmp_path / 'none.xml')) == 'failed'
