#!/usr/bin/env python3
"""My node flies the 5 m square at 3 m with velocity setpoints, each corner reached, then lands and disarms."""
import math

import rospy
import rostest
from offboard_py.testing import OffboardTestCase, Vehicle, now

ALTITUDE_M, SIDE_M = 3.0, 5.0


class SquareTest(OffboardTestCase):

    def test_flies_the_square_with_velocity_setpoints_then_lands(self):
        vehicle = Vehicle('mavros')
        self.wait_for_connected(vehicle, 30.0)
        self.wait_for_offboard_and_armed(vehicle, 60.0)
        x0, y0, _ = vehicle.positions[-1][1]                   # the square starts over the take-off point
        self.wait_for_altitude(vehicle, ALTITUDE_M, 0.3, 30.0)
        start = now()
        for cx, cy in ((SIDE_M, 0.0), (SIDE_M, SIDE_M), (0.0, SIDE_M), (0.0, 0.0)):
            self.wait_for_position(vehicle, (x0 + cx, y0 + cy, ALTITUDE_M), 30.0, horizontal_m=0.5, vertical_m=0.5)
        end = now()
        self.wait_for_mode(vehicle, 'AUTO.LAND', 20.0)
        self.wait_for_armed(vehicle, False, 60.0)             # landed and disarmed by PX4's land detector

        # the height held by the node's feedback all along the square
        with vehicle.lock:
            heights = [p[2] for t, p in vehicle.positions if start <= t <= end]
        worst = max(heights, key=lambda z: abs(z - ALTITUDE_M))
        self.assertLess(abs(worst - ALTITUDE_M), 0.5, 'the square left 3 +- 0.5 m: %.2f m' % worst)
        # what the node sent: velocity setpoints at 20 Hz on setpoint_raw/local, never a position
        velocities = vehicle.setpoint_values('velocity', since=start)
        self.assertGreater(len(velocities), 15 * (end - start),
                           'too few velocity setpoints (%d in %.0f s): %s'
                           % (len(velocities), end - start, vehicle.setpoint_counts()))
        self.assertEqual(vehicle.setpoint_values('position', since=start), [], 'the node sent a position')
        fastest = max(math.hypot(v[0], v[1]) for _, v in velocities)
        self.assertLessEqual(fastest, 1.0 + 1e-6, 'commanded %.2f m/s, more than ~speed 1 m/s' % fastest)


if __name__ == '__main__':
    rospy.init_node('test_square')
    rostest.rosrun('my_velocity_square', 'square', SquareTest)
