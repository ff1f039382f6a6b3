"""The demo and the launch files with a real part that is not there: one error naming it, then the end.

`./run demo fcu:=px4_sih` (takeoff_demo.py passes its name:=value arguments to start_offb.launch)
on a machine without a PX4 build, with an FCU nobody knows, and with bridge:=mavros where no mavros
is installed. Each run starts its own master on a free port through roslaunch; each must end by
itself, exit 1 and say what is missing, with no traceback.
"""

import os
import signal

import pytest

from offboard_py import stack
from offboard_py.testing.ports import free_tcp_port
from offboard_py.testing.processes import OutputProcess
from offboard_py.tools import demo

# roslaunch, the master and the first nodes start in a few seconds and the error ends it; on a loaded machine the
# demo's own bounds are the limit: MASTER_TIMEOUT_S for the master, as long again to join it, then the launch's end
END_S = 2 * demo.MASTER_TIMEOUT_S + 30.0


def run_demo(tmp_path, *launch_args):
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % free_tcp_port(), ROS_HOSTNAME='127.0.0.1',
               PYTHONUNBUFFERED='1', PX4_DIR='')
    proc = OutputProcess(['rosrun', 'offboard_py', 'takeoff_demo.py', '--timeout', '50', '--plot',
                          str(tmp_path / 'takeoff.png'), '--log', str(tmp_path / 'launch.log')] + list(launch_args),
                         env=env, new_session=True)
    try:
        code = proc.wait_exit(END_S)
        assert code is not None, 'the demo did not end within %.0f s:\n%s' % (END_S, proc.output)
        return code, proc.output
    finally:
        proc.stop(signal.SIGINT, timeout_s=15.0)


def test_demo_without_a_px4_build_names_it(tmp_path):
    code, out = run_demo(tmp_path, 'fcu:=px4_sih', 'px4_dir:=%s' % (tmp_path / 'PX4-Autopilot'))
    assert code == 1, out
    assert 'offb_node -> our mavros-compatible bridge -> real PX4 SITL (SIH quadrotor)' in out or \
        'before the ROS master came up' in out or 'before the demo joined its ROS master' in out, out
    assert 'px4_dir %s: no such folder' % (tmp_path / 'PX4-Autopilot') in out, out
    assert 'Traceback' not in out, out


def test_demo_with_an_unknown_fcu_names_the_choices(tmp_path):
    code, out = run_demo(tmp_path, 'fcu:=gazebo')
    assert code == 1, out
    assert 'fcu:=gazebo is not a flight controller this launch can start' in out, out


def test_demo_with_mavros_where_none_is_installed_names_it(tmp_path):
    if stack.rospack_find('mavros'):
        pytest.skip('real mavros is installed here: the cross-stack tier flies it instead')
    code, out = run_demo(tmp_path, 'bridge:=mavros')
    assert code == 1, out
    assert 'Resource not found: mavros' in out, out
