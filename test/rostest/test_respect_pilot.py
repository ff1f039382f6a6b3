#!/usr/bin/env python3
"""respect_pilot:=true beside the tutorial's default: a mode change from outside is left alone."""

import rospy
import rostest

from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle, now

PKG = 'offboard_py'


class RespectPilotTest(OffboardTestCase):

    def test_mode_change_from_outside(self):
        polite, default = Vehicle('uav0/mavros'), Vehicle('uav1/mavros')
        log = RosoutRecorder('/uav0/offb_node_py')
        both = [polite, default]
        self.wait_for_offboard_and_armed(both, 90.0, 'both OFFBOARD and armed')
        self.wait_until(lambda: all(abs(u.z() - 2.0) <= 0.15 for u in both), 30.0, 'both at 2 m', both)
        switched = now()
        for uav in both:  # the pilot takes over
            self.assertTrue(self.set_mode(uav, 'AUTO.LOITER'))
        for uav in both:  # the default node takes OFFBOARD back at its first AUTO.LOITER state: one HEARTBEAT (1 s)
            self.wait_for_mode(uav, 'AUTO.LOITER', 5.0, since=switched)

        def loiter_since(uav):
            return next(t for t, s in uav.states_since(switched) if s.mode == 'AUTO.LOITER')

        self.wait_for_mode(default, 'OFFBOARD', 15.0, since=loiter_since(default))
        self.pause(6.0)  # longer than the 5 s request interval
        modes = sorted({s.mode for _, s in polite.states_since(loiter_since(polite))})
        self.assertEqual(modes, ['AUTO.LOITER'],
                         'respect_pilot:=true must leave the pilot\'s mode alone (%s)' % polite.describe())
        self.assertTrue(any(line.startswith('Pilot took over') for line in log.lines), log.lines)

if __name__ == '__main__':
    rospy.init_node('test_respect_pilot')
    rostest.rosrun(PKG, 'respect_pilot', RespectPilotTest)
