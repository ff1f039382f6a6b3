#!/usr/bin/env python3
"""offb_node.py started with rosrun: parameter errors, waiting for the FCU, Ctrl-C."""

import os
import signal
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped

from offboard_py.testing.processes import OutputProcess

PKG = 'offboard_py'


def start_node(namespace, *args):
    """`rosrun offboard_py offb_node.py ARGS` in its own namespace, output collected."""
    return OutputProcess(['rosrun', PKG, 'offb_node.py', '__ns:=' + namespace] + list(args),
                         env=dict(os.environ, PYTHONUNBUFFERED='1'))


class NodeCliTest(unittest.TestCase):

    def test_rate_at_two_hz_is_refused(self):
        node = start_node('/cli_rate', '_rate:=2')
        code = node.wait_exit(30.0)
        self.assertIsNotNone(code, 'offb_node.py _rate:=2 still running after 30 s:\n' + node.output)
        self.assertNotEqual(code, 0, 'offb_node.py _rate:=2 exited 0:\n' + node.output)
        self.assertIn('~rate', node.output, 'the error does not name the parameter:\n' + node.output)
        self.assertNotIn('Traceback', node.output)

    def test_negative_prestream_count_is_refused(self):
        node = start_node('/cli_count', '_prestream_count:=-5')
        code = node.wait_exit(30.0)
        self.assertNotIn(code, (0, None), 'expected a non-zero exit:\n' + node.output)
        self.assertIn('~prestream_count', node.output, node.output)

    def test_waits_for_fcu_streams_nothing_and_exits_cleanly_on_ctrl_c(self):
        setpoints = []
        rospy.Subscriber('/cli_wait/mavros/setpoint_position/local', PoseStamped, setpoints.append)
        node = start_node('/cli_wait')
        self.assertTrue(node.wait_for_line('Waiting for the FCU connection', 30.0),
                        'no "Waiting for the FCU connection" message within 30 s:\n' + node.output)
        self.assertIn('/cli_wait/mavros/state', node.output, 'the message should name the topic')
        time.sleep(2.0)
        self.assertEqual(setpoints, [], 'setpoints were streamed before any FCU connection')
        self.assertIsNone(node.proc.poll(), 'the node exited while waiting:\n' + node.output)
        node.proc.send_signal(signal.SIGINT)
        code = node.wait_exit(15.0)
        self.assertEqual(code, 0, 'exit code %r after Ctrl-C:\n%s' % (code, node.output))
        self.assertNotIn('Traceback', node.output)


if __name__ == '__main__':
    rospy.init_node('test_node_cli')
    rostest.rosrun(PKG, 'node_cli', NodeCliTest)
