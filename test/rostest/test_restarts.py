#!/usr/bin/env python3
"""The bridge and the simulated PX4 killed (SIGKILL) in hover; the node keeps running.

- Bridge killed and respawned: the gap is longer than COM_OF_LOSS_T, so the vehicle fails
  safe (seen by a ground station on the GCS link); once the node's setpoints are back through the
  respawned bridge the vehicle flies OFFBOARD again, by itself as PX4 does or because the node,
  still the same process, asks again, and it returns to 2 m.
- Vehicle killed and restarted: the bridge reports disconnected, then connected; the new
  vehicle is on the ground, disarmed; the node arms it again and it climbs to 2 m.
"""

import os
import signal
import subprocess
import time
import xmlrpc.client

import rosgraph
import rospy
import rostest

from offboard_py.testing import Failures
from offboard_py.testing.rostest_common import START_WALL_S, OffboardTestCase, RosoutRecorder, Vehicle, now

PKG = 'offboard_py'


def node_pid(name, timeout_s=30.0):
    """The pid of node `name`, asked of the node the master names. Right after a respawn the master may still
    name the killed node (its last messages can arrive after the kill, so a test can get here first): asked
    again, for at most timeout_s wall seconds, until a node answers."""
    deadline = time.monotonic() + timeout_s
    while True:
        uri = rosgraph.Master('/test_restarts').lookupNode(name)
        try:
            code, _, pid = xmlrpc.client.ServerProxy(uri).getPid('/test_restarts')
            break
        except OSError as err:  # refused: the node that registered this URI is gone
            if time.monotonic() > deadline:
                raise AssertionError('node %s at %s did not answer within %.0f s: %s' % (name, uri, timeout_s, err))
            time.sleep(0.5)
    assert code == 1, 'getPid on %s failed' % name
    return pid


class RestartsTest(OffboardTestCase):

    def setUp(self):
        self.gcs = Failures(rospy.get_param('~instance'))  # a ground station: it sees the vehicle without the bridge

    def tearDown(self):
        self.gcs.close()

    def test_bridge_then_vehicle_restart(self):
        vehicle = Vehicle('mavros')
        node_log = RosoutRecorder('/offb_node_py')
        self.wait_for_connected(vehicle, 30.0)
        self.wait_back_at_2m(vehicle, 'start-up')
        node_before = node_pid('/offb_node_py')

        # the bridge dies: the vehicle fails safe COM_OF_LOSS_T later, and (as real PX4 SITL does, measured on
        # 02e73e3b6f) flies OFFBOARD again by itself once the node's setpoints come back through the respawned
        # bridge, which may be before that bridge's first state: the failsafe is seen on the ground station's link
        bridge_before = node_pid('/mavros')
        os.kill(bridge_before, signal.SIGKILL)
        killed, killed_ros = self.gcs.now(), now()

        def failsafe_seen():
            return next((mode for _, mode, armed in self.gcs.modes(killed) if mode != 'OFFBOARD'), None)
        self.wait_until(failsafe_seen, 30.0, 'the failsafe after the bridge was killed (on the GCS link)', [vehicle],
                        min_wall_s=START_WALL_S)
        rospy.loginfo('bridge killed: the vehicle went to %s', failsafe_seen())
        # what the killed bridge last said (OFFBOARD, armed, 2 m) stays until the respawned one speaks
        self.wait_until(lambda: any(s.connected for _, s in vehicle.states_since(killed_ros)), 30.0,
                        'the respawned bridge connected', [vehicle], min_wall_s=START_WALL_S)
        self.wait_back_at_2m(vehicle, 'the bridge respawned')
        self.assertNotEqual(node_pid('/mavros'), bridge_before, 'the bridge was not respawned')
        self.assertEqual(node_pid('/offb_node_py'), node_before, 'the node must not be restarted')
        # PX4 creeps over the last decimetre to 2 m (hover wander +-0.1 m): hold once within 0.1 m
        self.wait_for_altitude(vehicle, 2.0, 0.1, 30.0)
        self.assert_holds(vehicle, 2.0, 0.2, 2.0)

        # the vehicle dies
        pattern = rospy.get_param('~sim_pattern')
        pids = [int(p) for p in subprocess.run(['pgrep', '-f', pattern], capture_output=True, text=True).stdout.split()]
        self.assertEqual(len(pids), 1, 'expected one process matching %r, found %s' % (pattern, pids))
        arms_before = node_log.count('Vehicle armed')
        os.kill(pids[0], signal.SIGKILL)
        self.wait_until(lambda: not vehicle.state.connected, 3.0 + 2.0, 'disconnected after conn/timeout', [vehicle])
        self.wait_until(lambda: vehicle.state.connected, 30.0, 'connected to the restarted vehicle', [vehicle],
                        min_wall_s=START_WALL_S)
        self.assertFalse(vehicle.state.armed, 'a restarted vehicle is disarmed')
        self.wait_back_at_2m(vehicle, 'the vehicle restarted')
        self.assertGreater(node_log.count('Vehicle armed'), arms_before, 'the node did not re-arm')
        self.assertEqual(node_pid('/offb_node_py'), node_before, 'the node must not be restarted')
        self.assertIn('FCU connection back', node_log.lines)


if __name__ == '__main__':
    rospy.init_node('test_restarts')
    rostest.rosrun(PKG, 'restarts', RestartsTest)
