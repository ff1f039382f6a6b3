"""offb_node.py started before roscore: it says so, and connects when the master appears.

A real rosmaster on a port of its own (11392), started after the node; no FCU, so once
registered the node says it waits for the FCU connection.
"""

import os
import signal
import subprocess
import threading
import time

PORT = 11392
URI = 'http://127.0.0.1:%d' % PORT


class Output:
    def __init__(self, proc):
        self.text = ''
        threading.Thread(target=self._read, args=(proc,), daemon=True).start()

    def _read(self, proc):
        for line in proc.stdout:
            self.text += line

    def wait_for(self, words, timeout_s):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if words in self.text:
                return
            time.sleep(0.1)
        raise AssertionError('%r not said within %.0f s; output:\n%s' % (words, timeout_s, self.text[-3000:]))


def start(args):
    env = dict(os.environ, ROS_MASTER_URI=URI, ROS_HOSTNAME='127.0.0.1', PYTHONUNBUFFERED='1')
    return subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def stop(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            return proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


def test_node_waits_for_the_master_then_connects():
    node = start(['rosrun', 'offboard_py', 'offb_node.py'])
    master = None
    try:
        out = Output(node)
        out.wait_for('offb_node_py: no ROS master at %s (is roscore running?)' % URI, 15.0)
        time.sleep(1.0)
        assert node.poll() is None, 'the node gave up without a master:\n' + out.text
        master = start(['rosmaster', '--core', '-p', str(PORT)])
        out.wait_for('offb_node_py: ROS master found at %s' % URI, 15.0)
        out.wait_for('Waiting for the FCU connection on /mavros/state', 20.0)
        listed = subprocess.run(['rosnode', 'list'], env=dict(os.environ, ROS_MASTER_URI=URI),
                                capture_output=True, text=True, timeout=20).stdout
        assert '/offb_node_py' in listed.split(), listed
        assert stop(node) == 0
        assert 'Traceback' not in out.text, out.text
    finally:
        stop(node)
        if master is not None:
            stop(master)


def test_bounded_wait_gives_up_with_a_message():
    node = start(['rosrun', 'offboard_py', 'offb_node.py', '_master_timeout:=2'])
    out, _ = node.communicate(timeout=30)
    assert node.returncode == 1, out
    assert 'no ROS master at %s after 2 s' % URI in out, out
    assert 'Traceback' not in out, out


def test_interrupted_wait_exits_cleanly():
    node = start(['rosrun', 'offboard_py', 'offb_node.py'])
    out = Output(node)
    out.wait_for('no ROS master', 15.0)
    assert stop(node) == 0
    time.sleep(0.2)
    assert 'Traceback' not in out.text, out.text
