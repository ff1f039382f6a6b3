"""./run with real mavros built in the user's own catkin workspace: the workspace they had sourced, or the one
MAVROS_WS names in real-stack.conf, stays in reach after ./run sources ours (`./run demo bridge:=mavros`, the
cross-stack tier and `./run bench --compare` look mavros up with rospack there). A stand-in package named
mavros in a temporary workspace, built with catkin_make, plays real mavros."""

import os
import subprocess

import pytest

ROOT = os.path.realpath(os.path.join(os.path.dirname(__file__), '..', '..'))


@pytest.fixture(scope='module')
def user_ws(tmp_path_factory):
    ws = tmp_path_factory.mktemp('user_ws')
    pkg = ws / 'src' / 'mavros'
    pkg.mkdir(parents=True)
    (pkg / 'package.xml').write_text(
        '<?xml version="1.0"?>\n<package format="2"><name>mavros</name><version>1.21.0</version>'
        '<description>stand-in</description><maintainer email="x@example.com">x</maintainer>'
        '<license>BSD</license><buildtool_depend>catkin</buildtool_depend></package>\n')
    (pkg / 'CMakeLists.txt').write_text('cmake_minimum_required(VERSION 3.0.2)\nproject(mavros)\n'
                                        'find_package(catkin REQUIRED)\ncatkin_package()\n')
    env = {k: v for k, v in os.environ.items() if k not in ('CMAKE_PREFIX_PATH', 'ROS_PACKAGE_PATH')}
    built = subprocess.run(['catkin_make', '-C', str(ws), '-DPYTHON_EXECUTABLE=/usr/bin/python3'], cwd=str(ws), env=env,
                           capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stdout[-2000:] + built.stderr[-2000:]
    return ws


def found_in_run(prefix_path, conf=None):
    """Where `rospack find mavros` points after ./run's enter_workspace, with this CMAKE_PREFIX_PATH at the
    start (the caller's) and this real-stack.conf; (exit code, output)."""
    env = dict(os.environ, CMAKE_PREFIX_PATH=prefix_path, OFFBOARD_PY_REAL_STACK_CONF=conf or '/nonexistent')
    env.pop('ROS_PACKAGE_PATH', None)
    script = 'source "$1"; enter_workspace; rospack find mavros'
    done = subprocess.run(['bash', '-c', script, 'test', os.path.join(ROOT, 'run')], env=env, capture_output=True,
                          text=True, timeout=60)
    return done.returncode, done.stdout.strip() + done.stderr.strip()


def test_the_workspace_the_user_had_sourced_stays_in_reach(user_ws):
    code, out = found_in_run('%s/devel' % user_ws)
    assert code == 0 and out.endswith(str(user_ws / 'src' / 'mavros')), out


def test_mavros_ws_in_real_stack_conf(user_ws, tmp_path):
    conf = tmp_path / 'real-stack.conf'
    conf.write_text('MAVROS_WS=%s\n' % user_ws)
    code, out = found_in_run('', str(conf))
    assert code == 0 and out.endswith(str(user_ws / 'src' / 'mavros')), out
    conf.write_text('MAVROS_WS=%s\n' % (tmp_path / 'nowhere'))
    code, out = found_in_run('', str(conf))
    assert code != 0 and 'MAVROS_WS=%s' % (tmp_path / 'nowhere') in out, out


def test_without_a_user_workspace_there_is_no_mavros(user_ws):
    code, out = found_in_run('')
    assert code != 0, 'a mavros was found without the user workspace: %s' % out
