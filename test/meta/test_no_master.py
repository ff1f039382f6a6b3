"""offb_node.py started before roscore: it says so, and connects when the master appears.

A real rosmaster on a port of its own (a free one), started after the node; no FCU, so once
registered the node says it waits for the FCU connection.
"""

import os
import signal
import subprocess
import time

from offboard_py.testing.ports import free_tcp_port
from offboard_py.testing.processes import OutputProcess

PORT = free_tcp_port()
URI = 'http://127.0.0.1:%d' % PORT
# wall seconds for a Python node to start and say its first line: this tier runs niced beside the scenarios
# (./run test), and beside a busy loop as well (--hog) a start took over 15 s; the lines, not the time, are
# what these tests hold
START_S = 45.0


def start(args):
    env = dict(os.environ, ROS_MASTER_URI=URI, ROS_HOSTNAME='127.0.0.1', PYTHONUNBUFFERED='1')
    return OutputProcess(args, env=env)


def stop(proc):
    return proc.stop(signal.SIGINT, timeout_s=10.0)


def test_node_waits_for_the_master_then_connects():
    node = start(['rosrun', 'offboard_py', 'offb_node.py'])
    master = None
    try:
        node.expect_line('offb_node_py: no ROS master at %s (is roscore running?)' % URI, START_S)
        time.sleep(1.0)
        assert node.proc.poll() is None, 'the node gave up without a master:\n' + node.output
        master = start(['rosmaster', '--core', '-p', str(PORT)])
        node.expect_line('offb_node_py: ROS master found at %s' % URI, START_S)
        node.expect_line('Waiting for the FCU connection on /mavros/state', START_S)
        listed = subprocess.run(['rosnode', 'list'], env=dict(os.environ, ROS_MASTER_URI=URI),
                                capture_output=True, text=True, timeout=20).stdout
        assert '/offb_node_py' in listed.split(), listed
        assert stop(node) == 0
        assert 'Traceback' not in node.output, node.output
    finally:
        stop(node)
        if master is not None:
            stop(master)


def test_bounded_wait_gives_up_with_a_message():
    node = start(['rosrun', 'offboard_py', 'offb_node.py', '_master_timeout:=2'])
    code = node.wait_exit(START_S + 2.0)
    out = node.output
    assert code == 1, out
    assert 'no ROS master at %s after 2 s' % URI in out, out
    assert 'Traceback' not in out, out


def test_interrupted_wait_exits_cleanly():
    """Ctrl-C reaches the node only where SIGINT is not ignored: a test run in the background must give
    SIGINT back (./run's WITH_SIGINT), or this fails as it would for a user."""
    assert signal.getsignal(signal.SIGINT) is not signal.SIG_IGN, 'this test runs with SIGINT ignored'
    node = start(['rosrun', 'offboard_py', 'offb_node.py'])
    node.expect_line('no ROS master', START_S)
    assert stop(node) == 0
    time.sleep(0.2)
    assert 'Traceback' not in node.output, node.output
