#!/usr/bin/env python3
"""Two vehicles of multi_uav.launch at once: both take off together (~first: the first's id, 0)."""

import rospy
import rostest

from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle

PKG = 'offboard_py'


class TwoVehiclesTest(OffboardTestCase):

    def test_both_take_off(self):
        first = rospy.get_param('~first', 0)
        uavs = [Vehicle('uav%d/mavros' % first), Vehicle('uav%d/mavros' % (first + 1))]
        for uav in uavs:
            self.wait_for_connected(uav, 30.0)
        self.wait_for_offboard_and_armed(uavs, 60.0, 'both OFFBOARD and armed')
        # within 0.1 m before the +-0.15 m hold: PX4 creeps over the last decimetre to 2 m
        self.wait_until(lambda: all(abs(u.z() - 2.0) <= 0.1 for u in uavs), 30.0, 'both at 2 m', uavs)
        armed_at = [next(t for t, s in u.states if s.armed) for u in uavs]
        self.assertLess(abs(armed_at[0] - armed_at[1]), 5.0, 'they should fly together, not one after the other')
        for uav in uavs:
            self.assert_holds(uav, 2.0, 0.15, 2.0)

if __name__ == '__main__':
    rospy.init_node('test_two_vehicles')
    rostest.rosrun(PKG, 'two_vehicles', TwoVehiclesTest)
