#!/usr/bin/env python3
"""My node takes the vehicle to OFFBOARD, armed, and holds it 2 m over its start."""
import rospy
import rostest
from offboard_py.testing import OffboardTestCase, Vehicle


class HoverTest(OffboardTestCase):

    def test_reaches_and_holds_2m(self):
        vehicle = Vehicle('mavros')
        self.wait_for_connected(vehicle, 30.0)
        self.wait_for_offboard_and_armed(vehicle, 60.0)
        self.wait_for_position(vehicle, (0.0, 0.0, 2.0), 30.0, vertical_m=0.1)
        self.assert_holds_position(vehicle, (0.0, 0.0, 2.0), 5.0, vertical_m=0.2)


if __name__ == '__main__':
    rospy.init_node('test_hover')
    rostest.rosrun('my_offboard_check', 'hover', HoverTest)
