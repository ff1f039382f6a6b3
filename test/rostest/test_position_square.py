#!/usr/bin/env python3
"""PX4's mavros_posctl_test square, flown through mavros's interface only.

As PX4's test does: this node streams mavros/setpoint_position/local (PoseStamped, ENU) at
20 Hz from a timer, first at the origin on the ground; asks for OFFBOARD (mavros/set_mode) and
arms (mavros/cmd/arming); then sets the corners (50, 50, 20), (50, -50, 20), (-50, -50, 20),
(0, 0, 20) one after another, each reached within 1 m (test/sim/flight_profiles.py
POSCTL_SQUARE), within PX4's test's 30 s a corner. Each leg's pass, the time to the first pose
within PASS_RADIUS_M of its corner, is held to reference/px4-sitl-measured.md, section "The
flight" ("the posctl square ... legs 13.5 / 12.5-13.0 / 12.0-12.5 / 10.0-16.5 s"), and the
vehicle stays in OFFBOARD and armed throughout. Nothing here is our stack's own: it runs
unchanged on real mavros and real PX4.

Why the pass and not the 1 m: the vehicle overshoots each corner and passes the next one at
about 1 m (on our simulated PX4 0.64-1.11 m at corner 3 in sixteen runs, idle and loaded). A pass
just outside 1 m closes in slowly, about 6.5 s more: PX4's own leg 4 took 10.0 s in one run and
16.5 s in the other. Which of the two a run gets turns on centimetres, so the 1 m time would
test chance, where the pass tests the flight.
"""

import math
import threading

import rospy
import rostest
from geometry_msgs.msg import PoseStamped

from offboard_py.testing.reference import load
from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle, now

PKG = 'offboard_py'
# PX4's mavros_posctl_test square (ENU x east, y north, z up, m) and its acceptance radius
SQUARE = ((50.0, 50.0, 20.0), (50.0, -50.0, 20.0), (-50.0, -50.0, 20.0), (0.0, 0.0, 20.0))
RADIUS_M = 1.0
PASS_RADIUS_M = 1.5  # a leg is timed to here (see above)
REACH_TIMEOUT_S = 30.0  # PX4's mavros_posctl_test: reach_position(..., 30) for each corner
# reference/px4-sitl-measured.md, "The flight": each leg's time on PX4 SITL (s), fastest and slowest
LEGS_S = tuple(tuple(load('px4-sitl-flight-figures.json')['figures']['posctl_square']['leg_%d_s' % leg])
               for leg in range(1, 5))
# rostest's bounds are generous (the benchmark keeps the tight ones): 25 % either side of PX4's,
# for ROS's topic and service delays and a simulated clock
WIDEN = 0.25
SETPOINT_PERIOD_S = 0.05  # 20 Hz, as PX4's test and the tutorial stream
PRE_STREAM_S = 2.0  # PX4 takes OFFBOARD only with setpoints already arriving
DELIVERY_SLACK_S = 5.0  # simulated seconds a pose may come late on a busy machine at 5x (the leg is timed by stamp)
MAX_POSE_LAG_S = 0.5  # beyond this the lateness is logged
PASS_WINDOW_S = 1.0  # the pass's closest approach: up to this long after the pass radius (s, ROS time)
READY_S = 60.0  # PX4 SITL refuses arming until its estimator is ready


class PositionSquareTest(OffboardTestCase):

    def setUp(self):
        self.lock = threading.Lock()
        self.target = (0.0, 0.0, 0.0)
        self.pub = rospy.Publisher('mavros/setpoint_position/local', PoseStamped, queue_size=1)
        self.timer = None
        self.poses = []  # (header stamp, received, (x, y, z) ENU) since the last corner was set
        self.pose_sub = rospy.Subscriber('mavros/local_position/pose', PoseStamped, self._on_pose)

    def tearDown(self):
        if self.timer is not None:
            self.timer.shutdown()

    def _send(self, _event):
        with self.lock:
            x, y, z = self.target
        msg = PoseStamped()
        msg.header.stamp = rospy.Time.now()
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = x, y, z
        msg.pose.orientation.w = 1.0
        self.pub.publish(msg)

    def _on_pose(self, msg):
        p = msg.pose.position
        with self.lock:
            self.poses.append((msg.header.stamp.to_sec(), now(), (p.x, p.y, p.z)))

    def fly_to(self, vehicle, corner, timeout_s):
        """Set corner as the setpoint, wait until within RADIUS_M of it (in 3 D, as PX4's test), and
        return the pass: the time to the stamp of the first pose within PASS_RADIUS_M, the closest the
        poses came within PASS_WINDOW_S after it (as far as they have come), and when the corner was
        set. mavros stamps a pose with the FCU's own time of it (LOCAL_POSITION_NED.time_boot_ms,
        synchronised), so a pose delivered late by a busy machine does not lengthen the leg; the wait
        allows for that lateness."""
        with self.lock:
            self.target = corner
            self.poses = []
        start = now()

        def distances():
            with self.lock:
                poses = list(self.poses)
            return [(stamp, received, math.dist(p, corner)) for stamp, received, p in poses]

        def first_within(radius):
            return next(((stamp, received) for stamp, received, d in distances() if d <= radius), None)
        self.wait_until(lambda: first_within(RADIUS_M), timeout_s + DELIVERY_SLACK_S,
                        'corner ENU (%.0f, %.0f, %.0f) within %.0f m' % (corner + (RADIUS_M,)), [vehicle])
        stamp, received = first_within(PASS_RADIUS_M)
        if received - stamp > MAX_POSE_LAG_S:
            rospy.logwarn('the pose at corner %r came %.2f s after its stamp', corner, received - stamp)
        closest = min(d for s, _, d in distances() if s <= stamp + PASS_WINDOW_S)
        return stamp - start, closest, start

    @staticmethod
    def changes_since(vehicle, start):
        """The vehicle's (s since start, mode, armed) at each change since ROS time start: why a leg took long."""
        out = []
        for t, s in vehicle.states_since(start):
            if not out or out[-1][1:] != (s.mode, s.armed):
                out.append((round(t - start, 2), s.mode, s.armed))
        return out

    def test_square(self):
        vehicle = Vehicle('mavros')
        self.wait_for_connected(vehicle, 30.0)
        self.timer = rospy.Timer(rospy.Duration(SETPOINT_PERIOD_S), self._send)
        self.pause(PRE_STREAM_S)
        self.until_accepted(vehicle, 'mode OFFBOARD', lambda: self.set_mode(vehicle, 'OFFBOARD'),
                            lambda: vehicle.state.mode == 'OFFBOARD', READY_S)
        self.until_accepted(vehicle, 'arming in OFFBOARD', lambda: self.set_arm(vehicle, True).success,
                            vehicle.offboard_and_armed, READY_S)
        flying = now()

        for leg, (corner, runs) in enumerate(zip(SQUARE, LEGS_S), 1):
            lo, hi = min(runs) * (1.0 - WIDEN), max(runs) * (1.0 + WIDEN)
            took, closest, start = self.fly_to(vehicle, corner, REACH_TIMEOUT_S)
            rospy.loginfo('leg %d to %r: %.2f s to within %.1f m, passing at %.2f m (PX4 %.1f-%.1f s)',
                          leg, corner, took, PASS_RADIUS_M, closest, min(runs), max(runs))
            self.assertTrue(lo <= took <= hi, 'leg %d to ENU %r passed within %.1f m after %.2f s; PX4 %.1f-%.1f s, '
                            'allowed %.2f-%.2f s; the vehicle meanwhile (s, mode, armed): %r'
                            % (leg, corner, PASS_RADIUS_M, took, min(runs), max(runs), lo, hi,
                               self.changes_since(vehicle, start)))

        flight = [(round(t - flying, 2), s.mode, s.armed) for t, s in vehicle.states_since(flying)]
        self.assertTrue(flight, 'no state during the square')
        self.assertTrue(all(mode == 'OFFBOARD' and armed for _, mode, armed in flight),
                        'OFFBOARD and armed throughout the square: %r' % flight)


if __name__ == '__main__':
    rospy.init_node('test_position_square')
    rostest.rosrun(PKG, 'position_square', PositionSquareTest)
