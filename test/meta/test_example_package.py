"""The example of README's "Test your own node" works as a user's package: built, run, and able to fail.

examples/my_offboard_check is copied into a temporary catkin workspace chained on the one this
test runs in (the workspace that holds offboard_py, already sourced), built with catkin_make by
the Python on PATH, and its rostest run in a network namespace of its own (`unshare -n`, or
`unshare -rn` without root; skipped, saying why, when neither is allowed), so its vehicle's ports
clash with nothing. Its result is read from rostest's RESULT line and the JUnit file it writes.
Then, told to fly to 1 m instead of 2, it must fail saying where the vehicle was. Its failsafe test (the
battery drained by the test kit's Failures) runs too.
"""

import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

import pytest

REPO = os.path.realpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..'))
EXAMPLE = os.path.join(REPO, 'examples', 'my_offboard_check')
BUILD_TIMEOUT_S = 300.0
ROSTEST_TIMEOUT_S = 300.0
ANSI_COLOUR = re.compile(r'\x1b\[[0-9;]*m')  # rostest colours its summary
# The example's flights run in the processes tier, niced beside the scenarios under ./run test: at 5x a 0.1 s
# stall of the niced flight is 0.5 s of simulated time and the clock guard rightly calls the run untrustworthy
# (seen on a fresh clone), and at 2x beside the hog a 0.36 s stall was (0.72 s simulated, one fresh clone of
# five), so they fly in real time, where no /clock can fall behind
EXAMPLE_MAX_SPEED = 1.0


def example_speed():
    return min(float(os.environ.get('OFFBOARD_PY_SPEED', '1') or 1), EXAMPLE_MAX_SPEED)


def _isolation():
    """The unshare command that gives a process a network namespace of its own here, or None."""
    if shutil.which('unshare') is None:
        return None
    for command in (['unshare', '-n'], ['unshare', '-rn']):
        try:
            if subprocess.run(command + ['true'], capture_output=True, timeout=10).returncode == 0:
                return command
        except subprocess.TimeoutExpired:
            pass
    return None


def _run(script, timeout_s, what):
    """bash -c script; (returncode, output). Fails naming `what` and showing the output's end on a timeout."""
    # a make of ours around this one (catkin's run_tests) would hand it a jobserver it cannot reach
    env = {k: v for k, v in os.environ.items() if k not in ('MAKEFLAGS', 'MFLAGS', 'MAKELEVEL')}
    try:
        out = subprocess.run(['bash', '-c', script], capture_output=True, text=True, timeout=timeout_s, env=env)
    except subprocess.TimeoutExpired as err:
        pytest.fail('%s did not finish within %.0f s; its output ended:\n%s'
                    % (what, timeout_s, ((err.stdout or b'').decode(errors='replace'))[-3000:]))
    return out.returncode, out.stdout + out.stderr


@pytest.fixture(scope='module')
def workspace():
    """A catkin workspace with the example package, built; yields its devel/setup.bash."""
    if shutil.which('catkin_make') is None:
        pytest.skip('catkin_make is not on PATH (run in ./run shell)')
    if not os.environ.get('CMAKE_PREFIX_PATH'):
        pytest.skip('no catkin workspace is sourced (source the devel/setup.bash that holds offboard_py)')
    with tempfile.TemporaryDirectory(prefix='my_ws-') as ws:
        os.makedirs(os.path.join(ws, 'src'))
        shutil.copytree(EXAMPLE, os.path.join(ws, 'src', 'my_offboard_check'))
        start = time.monotonic()
        code, output = _run('cd %s && catkin_make -DPYTHON_EXECUTABLE="$(command -v python3)"' % shlex.quote(ws),
                            BUILD_TIMEOUT_S, 'catkin_make of the example workspace')
        assert code == 0, 'catkin_make of the example package failed:\n' + output[-4000:]
        print('example workspace built in %.1f s' % (time.monotonic() - start))
        yield os.path.join(ws, 'devel', 'setup.bash')


def run_example(setup_bash, *launch_args, test_file='hover.test'):
    """rostest my_offboard_check TEST_FILE in a network namespace of its own; (RESULT line, failure texts, output)."""
    unshare = _isolation()
    if unshare is None:
        pytest.skip('no network namespace for the example\'s vehicle (unshare -n and unshare -rn are not allowed '
                    'here), and on the shared loopback its ports could clash with other tests')
    with tempfile.TemporaryDirectory(prefix='my_results-') as results:
        inner = ('ip link set lo up && source %s && export ROS_HOSTNAME=localhost OFFBOARD_PY_SPEED=%g && '
                 'unset ROS_IP && exec rostest --results-base-dir %s my_offboard_check %s %s'
                 % (shlex.quote(setup_bash), example_speed(), shlex.quote(results), test_file,
                    ' '.join(map(shlex.quote, launch_args))))
        start = time.monotonic()
        _, output = _run(' '.join(map(shlex.quote, unshare + ['bash', '-c', inner])), ROSTEST_TIMEOUT_S,
                         'rostest my_offboard_check %s %s' % (test_file, ' '.join(launch_args)))
        print('rostest my_offboard_check %s %s: %.1f s' % (test_file, ' '.join(launch_args), time.monotonic() - start))
        result = next((ANSI_COLOUR.sub('', line).strip() for line in output.splitlines() if ' * RESULT: ' in line),
                      None)
        files = [os.path.join(d, f) for d, _, fs in os.walk(results) for f in fs if f.startswith('rosunit-')]
        assert files, 'rostest wrote no result file; it said:\n' + output[-4000:]
        suites = [ET.parse(f).getroot() for f in files]
        tests = sum(int(s.get('tests', 0)) for s in suites)
        assert tests >= 1, 'the example ran no test; rostest said:\n' + output[-4000:]
        failures = [(node.get('message') or '') + (node.text or '')
                    for s in suites for node in s.iter() if node.tag in ('failure', 'error')]
    return result, failures, output


def test_the_example_package_builds_and_passes(workspace):
    result, failures, output = run_example(workspace)
    assert not failures, 'the example failed:\n%s\nrostest said:\n%s' % ('\n'.join(failures), output[-3000:])
    assert result == '* RESULT: SUCCESS', \
        'rostest did not say RESULT: SUCCESS (%r); it said:\n%s' % (result, output[-3000:])


def test_the_example_failsafe_test_passes(workspace):
    """failsafe.test: the battery drained to 6 % by the test kit's Failures; the node leaves PX4's return alone."""
    result, failures, output = run_example(workspace, test_file='failsafe.test')
    assert not failures, 'the failsafe example failed:\n%s\nrostest said:\n%s' % ('\n'.join(failures), output[-3000:])
    assert result == '* RESULT: SUCCESS', (result, output[-3000:])


def test_the_example_fails_when_the_node_flies_elsewhere(workspace):
    """The node told to fly to 1 m: the example's wait for 2 m must fail, saying where the vehicle was."""
    result, failures, output = run_example(workspace, 'z:=1.0')
    assert result is not None and 'SUCCESS' not in result, \
        'the example passed with the node at 1 m (%r); rostest said:\n%s' % (result, output[-3000:])
    message = ' '.join(failures)
    expected = 'position ENU (0.00, 0.00, 2.00) +- 1.00 m horizontally, +- 0.10 m vertically did not happen'
    assert expected in message, message
    assert 'OFFBOARD' in message and 'armed' in message and 'ENU (' in message, message


def test_the_public_api_resolves_and_loads_no_ros_until_used():
    """Every name offboard_py.testing exports resolves, and importing the package alone loads neither
    rospy nor pymavlink (the ROS-free tiers and a user's pymavlink tests import it too)."""
    script = ('import sys, offboard_py.testing as t\n'
              'loaded = [m for m in ("rospy", "pymavlink") if m in sys.modules]\n'
              'assert not loaded, "importing offboard_py.testing loaded %s" % loaded\n'
              'missing = [n for n in t.__all__ if getattr(t, n, None) is None]\n'
              'assert not missing, "exported but not there: %s" % missing\n')
    out = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
