#!/usr/bin/env python3
"""Two vehicles of multi_uav.launch at once: both take off together (~first: the first's id, 0)."""

import rospy
import rostest

from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle

PKG = 'offboard_py'
# offb_node's request spacing (the tutorial's 5 s): a vehicle that needed one request more than the other,
# or that waited for the other, arms this much later on its own schedule
REQUEST_INTERVAL_S = 5.0


class TwoVehiclesTest(OffboardTestCase):

    def test_both_take_off(self):
        first = rospy.get_param('~first', 0)
        uavs = [Vehicle('uav%d/mavros' % first), Vehicle('uav%d/mavros' % (first + 1))]
        for uav in uavs:
            self.wait_for_connected(uav, 30.0)
        self.wait_for_offboard_and_armed(uavs, 60.0, 'both OFFBOARD and armed')
        # within 0.1 m before the +-0.15 m hold: PX4 creeps over the last decimetre to 2 m
        self.wait_until(lambda: all(abs(u.z() - 2.0) <= 0.1 for u in uavs), 30.0, 'both at 2 m', uavs)
        # Each node's schedule runs from its first setpoint (it streams once it sees the connection). The two
        # stacks start a second or two apart in wall time, which simulated time at OFFBOARD_PY_SPEED
        # multiplies, so the arming times themselves may be 5 s apart; the time each node took from its
        # first setpoint to armed may not: that is the same tutorial schedule on two independent stacks.
        unseen = [u.ns for u in uavs if not u.setpoints]
        if unseen:
            self.fail('no setpoint of offb_node seen on %s/setpoint_position/local: its schedule cannot be timed'
                      % ', '.join(unseen))
        started_at = [u.setpoints[0] for u in uavs]
        armed_at = [next(t for t, s in u.states if s.armed) for u in uavs]
        took = [a - s for a, s in zip(armed_at, started_at)]
        rospy.loginfo('first setpoint at %s, armed at %s: %s s from first setpoint to armed',
                      started_at, armed_at, ['%.2f' % t for t in took])
        self.assertLess(abs(took[0] - took[1]), REQUEST_INTERVAL_S,
                        'they should fly together, not one after the other: from its first setpoint to armed '
                        '%s took %.2f s, %s %.2f s' % (uavs[0].ns, took[0], uavs[1].ns, took[1]))
        for uav in uavs:
            self.assert_holds(uav, 2.0, 0.15, 2.0)

if __name__ == '__main__':
    rospy.init_node('test_two_vehicles')
    rostest.rosrun(PKG, 'two_vehicles', TwoVehiclesTest)
