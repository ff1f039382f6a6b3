#!/usr/bin/env python3
"""respect_pilot:=true beside the tutorial's default: a mode change from outside is left alone."""

import rospy
import rostest

from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle

PKG = 'offboard_py'


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
    rospy.init_node('test_respect_pilot')
    rostest.rosrun(PKG, 'respect_pilot', RespectPilotTest)
