#!/usr/bin/env python3
"""Two vehicles at once: both take off together; and respect_pilot against the default."""

import sys

import rospy
import rostest

from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle, now

PKG = 'offboard_py'


class TwoVehiclesTest(OffboardTestCase):

    def test_both_take_off(self):
        uavs = [Vehicle('uav0/mavros'), Vehicle('uav1/mavros')]
        for uav in uavs:
            self.wait_for_connected(uav, 30.0)
        self.wait_for_offboard_and_armed(uavs, 60.0, 'both OFFBOARD and armed')
        # within 0.1 m before the +-0.15 m hold: PX4 creeps over the last decimetre to 2 m
        self.wait_until(lambda: all(abs(u.z() - 2.0) <= 0.1 for u in uavs), 30.0, 'both at 2 m', uavs)
        armed_at = [next(t for t, s in u.states if s.armed) for u in uavs]
        self.assertLess(abs(armed_at[0] - armed_at[1]), 5.0, 'they should fly together, not one after the other')
        for uav in uavs:
            self.assert_holds(uav, 2.0, 0.15, 2.0)


class RespectPilotTest(OffboardTestCase):

    def test_mode_change_from_outside(self):
        polite, default = Vehicle('uav0/mavros'), Vehicle('uav1/mavros')
        log = RosoutRecorder('/uav0/offb_node_py')
        both = [polite, default]
        self.wait_for_offboard_and_armed(both, 90.0, 'both OFFBOARD and armed')
        self.wait_until(lambda: all(abs(u.z() - 2.0) <= 0.15 for u in both), 30.0, 'both at 2 m', both)
        for uav in both:  # the pilot takes over
            self.assertTrue(self.set_mode(uav, 'AUTO.LOITER'))
        self.wait_until(lambda: all(u.state.mode == 'AUTO.LOITER' for u in both), 5.0, 'both in AUTO.LOITER', both)
        self.wait_until(lambda: default.state.mode == 'OFFBOARD', 15.0,
                        'the default node taking OFFBOARD back', both)
        self.pause(6.0)  # longer than the 5 s request interval
        self.assertEqual(polite.state.mode, 'AUTO.LOITER',
                         'respect_pilot:=true must leave the pilot\'s mode alone (%s)' % polite.describe())
        self.assertTrue(any(line.startswith('Pilot took over') for line in log.lines), log.lines)


if __name__ == '__main__':
    rospy.init_node('test_multi')
    which = rospy.myargv(sys.argv)[1]
    case = {'two_vehicles': TwoVehiclesTest, 'respect_pilot': RespectPilotTest}[which]
    rostest.rosrun(PKG, which, case)
