#!/usr/bin/env python3
"""offb_figure.py: the tutorial's node with its own setpoint_at() flies a figure of eight at 2 m, 2 m either way
along x and 1 m along y, a lap every 20 s, and the setpoints it streams move along the figure."""

import math

import rospy
import rostest

from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle, now

PKG = 'offboard_py'
RADIUS_M, PERIOD_S, ALTITUDE_M = 2.0, 20.0, 2.0  # figure.test's
TRACK_M = 0.8  # how far off the figure the vehicle may fly at up to 0.63 m/s: PX4 trails a moving setpoint (MPC_XY_P
# 0.95 1/s: about 0.66 m at that speed) and cuts the curves; the simulated PX4 flew 0.46 m off


def distance_to_figure(x, y):
    """The distance of (x, y) from the lemniscate x = R sin a, y = R sin a cos a (sampled finely)."""
    return min(math.hypot(x - RADIUS_M * math.sin(a), y - RADIUS_M * math.sin(a) * math.cos(a))
               for a in (2.0 * math.pi * k / 720 for k in range(720)))


class FigureTest(OffboardTestCase):

    def test_flies_a_figure_of_eight(self):
        vehicle = Vehicle('mavros')
        self.wait_for_connected(vehicle, 30.0)
        self.wait_for_offboard_and_armed(vehicle, 60.0)
        self.wait_for_altitude(vehicle, ALTITUDE_M, 0.3, 30.0)
        start = now()
        self.pause(PERIOD_S)  # one lap
        with vehicle.lock:
            lap = [p for t, p in vehicle.positions if t >= start]
        self.assertGreater(len(lap), 10 * PERIOD_S, 'too few poses in the lap: %d' % len(lap))
        worst = max(lap, key=lambda p: distance_to_figure(p[0], p[1]))
        self.assertLess(distance_to_figure(worst[0], worst[1]), TRACK_M,
                        'off the figure by %.2f m at ENU (%.2f, %.2f)' % ((distance_to_figure(worst[0], worst[1]),)
                                                                          + worst[:2]))
        xs, ys = [p[0] for p in lap], [p[1] for p in lap]
        rospy.loginfo('the lap: %d poses, at most %.2f m off the figure, x %.2f..%.2f m, y %.2f..%.2f m', len(lap),
                      distance_to_figure(worst[0], worst[1]), min(xs), max(xs), min(ys), max(ys))
        self.assertGreater(max(xs) - min(xs), 2 * RADIUS_M - 2 * TRACK_M, 'x spanned %.2f m' % (max(xs) - min(xs)))
        self.assertGreater(max(ys) - min(ys), RADIUS_M - 2 * TRACK_M, 'y spanned %.2f m' % (max(ys) - min(ys)))
        self.assertLess(max(abs(p[2] - ALTITUDE_M) for p in lap), 0.5, 'the lap left 2 +- 0.5 m')
        targets = vehicle.setpoint_values('position', since=start)
        # on the figure to within its sampling here (720 points: 2.5 cm apart at most)
        self.assertTrue(all(distance_to_figure(p[0], p[1]) < 0.03 for _, p in targets),
                        'a setpoint off the figure: %r' % [p for _, p in targets][:5])
        self.assertGreater(len(targets), 15 * PERIOD_S, 'too few setpoints in the lap: %d' % len(targets))
        self.assertTrue(vehicle.offboard_and_armed(), vehicle.describe())


if __name__ == '__main__':
    rospy.init_node('test_figure')
    rostest.rosrun(PKG, 'figure', FigureTest)
