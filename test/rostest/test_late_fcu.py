#!/usr/bin/env python3
"""The node started before the vehicle waits (streams nothing), then flies when it appears."""


import rospy
import rostest

from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle

PKG = 'offboard_py'


class LateFcuTest(OffboardTestCase):

    def test_waits_then_flies(self):
        vehicle = Vehicle('mavros')
        log = RosoutRecorder('/offb_node_py')
        setpoints = vehicle.setpoints
        self.pause(4.0)
        self.assertFalse(vehicle.state.connected, 'no vehicle yet: %s' % vehicle.describe())
        self.assertEqual(setpoints, [], 'nothing is streamed before the FCU is connected')
        self.wait_for_connected(vehicle, 60.0)
        self.wait_for_offboard_and_armed(vehicle, 60.0)
        self.wait_for_altitude(vehicle, 2.0, 0.15, 30.0)
        self.assertTrue(any('Waiting for the FCU connection' in line for line in log.lines), log.lines)


if __name__ == '__main__':
    rospy.init_node('test_late_fcu')
    rostest.rosrun(PKG, 'late_fcu', LateFcuTest)
