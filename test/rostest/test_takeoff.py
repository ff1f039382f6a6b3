#!/usr/bin/env python3
"""The tutorial's flight, end to end: OFFBOARD, armed, 2 m held, and the node said so once each."""

import rospy
import rostest

from offboard_py.testing.reference import load
from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle

PKG = 'offboard_py'
# the widest of PX4 SITL's recorded hovers, with the flight fit's 10 %
HOVER_WANDER_M = 1.1 * max(load('px4-sitl-hover.json')['hover_80s']['max_abs_z_minus_2_m'])


class TakeoffTest(OffboardTestCase):

    def test_takeoff_and_hold_2m(self):
        vehicle = Vehicle('mavros')
        log = RosoutRecorder('/offb_node_py')
        setpoints = vehicle.setpoints
        self.wait_for_connected(vehicle, 30.0)
        try:
            self.wait_for_offboard_and_armed(vehicle, rospy.get_param('~deadline', 60.0))
        except AssertionError as err:
            raise AssertionError('%s; setpoints streamed by the node: %d; node said: %s'
                                 % (err, len(setpoints), log.lines[-5:]))
        # PX4 creeps over the last decimetre to 2 m (P control): hold once within 0.1 m, then within the wander of
        # PX4 SITL's own hovers at 2 m (reference/px4-sitl-hover.json: 0.24 m; real mavros on real PX4 read 1.81 m
        # 3 s after 2.0 m, where this held 0.15 m)
        self.wait_for_altitude(vehicle, 2.0, 0.1, 30.0)
        self.assert_holds(vehicle, 2.0, HOVER_WANDER_M, 3.0)
        self.assertEqual(log.count('OFFBOARD enabled'), 1, 'node log: %s' % log.lines)
        self.assertEqual(log.count('Vehicle armed'), 1, 'node log: %s' % log.lines)


if __name__ == '__main__':
    rospy.init_node('test_takeoff')
    rostest.rosrun(PKG, 'takeoff', TakeoffTest)
