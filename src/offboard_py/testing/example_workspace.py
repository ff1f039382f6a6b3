"""The example packages of examples/, built as a user builds them and their rostests run as a user runs them.

For the processes tier (test/meta/test_example_package.py: on the simulated PX4, in network namespaces of
their own) and the cross-stack tier (offboard_py.testing.cross_stack: the same tests, unchanged, on real PX4
SITL and real mavros by OFFBOARD_PY_FCU and OFFBOARD_PY_BRIDGE alone, as docs/testing.md tells users to).
A workspace here is chained on the one that holds offboard_py (sourced by the caller) and built with
catkin_make by the Python first on PATH, as docs/install.md says.
"""

import collections
import os
import re
import shlex
import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ElementTree

REPO = os.path.realpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', '..'))
EXAMPLES = os.path.join(REPO, 'examples')
# every example test: (package, .test file, the instance its CMakeLists.txt gives it)
TESTS = (('my_offboard_check', 'hover.test', 30),
         ('my_offboard_check', 'failsafe.test', 31),
         ('my_velocity_square', 'square.test', 32))
PACKAGES = tuple(sorted({package for package, _, _ in TESTS}))
# Wall-clock bounds, generous: the build is C++ (mavros_msgs' 124 interfaces), and the processes tier runs it at
# nice 10 beside the scenarios; under two busy loops it had reached 40 % after 300 s. A loaded machine makes
# this slower, not wrong.
BUILD_TIMEOUT_S = 1200.0
ROSTEST_TIMEOUT_S = 900.0
ANSI_COLOUR = re.compile(r'\x1b\[[0-9;]*m')  # rostest colours its summary

# what one rostest run said: rostest's RESULT line (None when it printed none), the JUnit failure and error
# texts, how many tests the JUnit files count, and rostest's output
Outcome = collections.namedtuple('Outcome', 'result failures tests output')


class Timeout(Exception):
    """A build or a rostest run that did not finish in time; the message says which and how its output ended."""


def clean_environment(extra=None):
    """os.environ without a make jobserver of ours (catkin's run_tests around a test would hand one over that a
    child cannot reach), updated with extra (a value None removes the variable)."""
    env = {k: v for k, v in os.environ.items() if k not in ('MAKEFLAGS', 'MFLAGS', 'MAKELEVEL')}
    for name, value in (extra or {}).items():
        if value is None:
            env.pop(name, None)
        else:
            env[name] = value
    return env


def run_bash(script, timeout_s, what, env=None):
    """bash -c script; (returncode, stdout + stderr). Raises Timeout naming `what`."""
    try:
        out = subprocess.run(['bash', '-c', script], capture_output=True, text=True, timeout=timeout_s,
                             env=clean_environment(env))
    except subprocess.TimeoutExpired as err:
        raise Timeout('%s did not finish within %.0f s; its output ended:\n%s'
                      % (what, timeout_s, (err.stdout or b'').decode(errors='replace')[-3000:]))
    return out.returncode, out.stdout + out.stderr


def build(ws, packages=PACKAGES):
    """Copy the example packages into ws/src and catkin_make them; (returncode, output, ws/devel/setup.bash)."""
    os.makedirs(os.path.join(ws, 'src'), exist_ok=True)
    for package in packages:
        shutil.copytree(os.path.join(EXAMPLES, package), os.path.join(ws, 'src', package))
    code, output = run_bash('cd %s && catkin_make -DPYTHON_EXECUTABLE="$(command -v python3)"' % shlex.quote(ws),
                            BUILD_TIMEOUT_S, 'catkin_make of the example workspace')
    return code, output, os.path.join(ws, 'devel', 'setup.bash')


# what a user's clone of offboard_py does not hold: this checkout's own workspace, environment and history
NOT_CLONED = shutil.ignore_patterns('.git', '.ws', '.venv', '__pycache__', '*.pyc', 'real-stack.conf')
# a workspace sourced by the caller, which a workspace of the user's own must not see
WORKSPACE_VARIABLES = ('CMAKE_PREFIX_PATH', 'ROS_PACKAGE_PATH', 'PYTHONPATH', 'LD_LIBRARY_PATH', 'PKG_CONFIG_PATH',
                       'ROSLISP_PACKAGE_DIRECTORIES', 'ROS_ROOT', 'ROS_DISTRO', 'ROS_ETC_DIR', 'ROS_VERSION',
                       'ROS_PYTHON_VERSION')


def build_user_workspace(ws, packages=PACKAGES):
    """A workspace as docs/install.md makes one, with no other workspace sourced: offboard_py (this
    checkout's files) in src/, the links to its two interface packages beside it, and the example packages;
    catkin_make by the Python first on PATH. (returncode, output, ws/devel/setup.bash)"""
    src = os.path.join(ws, 'src')
    shutil.copytree(REPO, os.path.join(src, 'offboard_py'), ignore=NOT_CLONED)
    for interface in ('mavros_msgs', 'geographic_msgs'):
        os.symlink(os.path.join('offboard_py', 'interfaces', interface), os.path.join(src, interface))
    for package in packages:
        shutil.copytree(os.path.join(EXAMPLES, package), os.path.join(src, package))
    code, output = run_bash('cd %s && catkin_make -DPYTHON_EXECUTABLE="$(command -v python3)"' % shlex.quote(ws),
                            BUILD_TIMEOUT_S, 'catkin_make of the user workspace', standalone_environment())
    return code, output, os.path.join(ws, 'devel', 'setup.bash')


def standalone_environment():
    """The caller's environment without its sourced workspace (run_bash's env: None removes a variable)."""
    return {name: None for name in WORKSPACE_VARIABLES}


def read_results_file(path):
    """(failure and error texts, test count) of one JUnit file."""
    root = ElementTree.parse(path).getroot()
    suites = [root] if root.tag == 'testsuite' else list(root.iter('testsuite'))
    failures = [(node.get('message') or '') + (node.text or '')
                for node in root.iter() if node.tag in ('failure', 'error')]
    return failures, sum(int(s.get('tests', 0)) for s in suites)


def read_results(results_dir):
    """(failure and error texts, test count) of the rosunit JUnit files under results_dir."""
    failures, tests = [], 0
    for path in (os.path.join(d, f) for d, _, fs in os.walk(results_dir) for f in fs if f.startswith('rosunit-')):
        more, count = read_results_file(path)
        failures, tests = failures + more, tests + count
    return failures, tests


def run_rostest(setup_bash, package, test_file, launch_args=(), env=None, isolate=None, results_dir=None,
                timeout_s=ROSTEST_TIMEOUT_S):
    """rostest PACKAGE TEST_FILE LAUNCH_ARGS with setup_bash sourced and env added; in a network namespace of
    its own when isolate is an unshare command (['unshare', '-n']). The JUnit files go to results_dir (a
    temporary folder when None). An Outcome; raises Timeout."""
    own_results = results_dir is None
    results_dir = tempfile.mkdtemp(prefix='example-results-') if own_results else results_dir
    try:
        inner = ('source %s && export ROS_HOSTNAME=localhost && unset ROS_IP && exec rostest --results-base-dir %s '
                 '%s %s %s' % (shlex.quote(setup_bash), shlex.quote(results_dir), package, test_file,
                               ' '.join(map(shlex.quote, launch_args))))
        if isolate:
            inner = ' '.join(map(shlex.quote, list(isolate) + ['bash', '-c', 'ip link set lo up && ' + inner]))
        _, output = run_bash(inner, timeout_s, 'rostest %s %s %s' % (package, test_file, ' '.join(launch_args)), env)
        result = next((ANSI_COLOUR.sub('', line).strip() for line in output.splitlines() if ' * RESULT: ' in line),
                      None)
        failures, tests = read_results(results_dir)
        return Outcome(result, failures, tests, output)
    finally:
        if own_results:
            shutil.rmtree(results_dir, ignore_errors=True)


def passed(outcome):
    return outcome.tests >= 1 and not outcome.failures and outcome.result == '* RESULT: SUCCESS'
