#!/usr/bin/env python3
"""PX4's integration-test mission MC_mission_box, flown through mavros's interface only.

The six items of reference/px4-sitl-measured.md, section "AUTO modes" (home 47.397742,
8.545594; frame GLOBAL_REL_ALT) go up with mavros/mission/push; then AUTO.MISSION
(mavros/set_mode) and arming (mavros/cmd/arming), as there. Held to that section's two PX4 runs:
items 0..4 reached in order (mavros/mission/reached), each at its time after the arm, the
landing (mavros/extended_state) at its time, then the disarm; AUTO.MISSION and armed throughout
the flight. Nothing here is our stack's own: it runs unchanged on real mavros and real PX4.
"""

import rospy
import rostest
from mavros_msgs.msg import ExtendedState, Waypoint, WaypointReached
from mavros_msgs.srv import WaypointPush

from offboard_py.testing.measured_tables import MISSION_BOX
from offboard_py.testing.reference import load, px4_rate_hz
from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle, now

PKG = 'offboard_py'
NAN = float('nan')
# PX4 SITL's figures (reference/px4-sitl-measured.md, checked by test_reference_figures); the same section,
# the two PX4 runs: arm -> MISSION_ITEM_REACHED 0..4 and arm -> landed (s)
_PX4 = load('px4-sitl-flight-figures.json')
REACHED_S = tuple(tuple(_PX4['figures']['mission']['arm_to_item_%d_s' % seq]) for seq in range(5))
LANDED_S = tuple(_PX4['figures']['mission']['arm_to_landed_s'])
LANDED_TO_DISARMED_S = max(_PX4['not_compared']['mission landed -> disarmed (s)'])  # the slower run
# rostest's bounds are generous (the benchmark keeps the tight ones): 25 % either side of the runs,
# for ROS's topic and service delays and a simulated clock
WIDEN = 0.25
STATE_PERIOD_S = 1.0 / px4_rate_hz('HEARTBEAT')  # mavros publishes armed with each HEARTBEAT: up to a period late
# mavros publishes landed_state with each EXTENDED_SYS_STATE, 5 Hz on the onboard link
# (reference/px4-sitl-measured.md, "The onboard link"): up to that period late, and a delivery
LANDED_SEEN_LATE_S = 0.2 + 0.1
READY_S = 60.0  # PX4 SITL refuses AUTO.MISSION and arming until its estimator has a global position


def bounds(runs):
    return min(runs) * (1.0 - WIDEN), max(runs) * (1.0 + WIDEN)


def mission_box():
    waypoints = []
    for seq, (command, lat, lon, alt) in enumerate(MISSION_BOX):
        wp = Waypoint()
        wp.frame, wp.command, wp.is_current, wp.autocontinue = Waypoint.FRAME_GLOBAL_REL_ALT, command, seq == 0, True
        # param4 (yaw) NaN: PX4 keeps its heading; the other params 0: PX4's defaults (acceptance radius NAV_ACC_RAD)
        wp.param1, wp.param2, wp.param3, wp.param4 = 0.0, 0.0, 0.0, NAN
        wp.x_lat, wp.y_long, wp.z_alt = lat, lon, alt
        waypoints.append(wp)
    return waypoints


class MissionTest(OffboardTestCase):

    def setUp(self):
        self.reached = []        # (time, seq): PX4 sends each MISSION_ITEM_REACHED again up to 10 times
        self.landed_states = []  # (time, landed_state)
        self.subs = [rospy.Subscriber('mavros/mission/reached', WaypointReached,
                                      lambda msg: self.reached.append((now(), msg.wp_seq))),
                     rospy.Subscriber('mavros/extended_state', ExtendedState,
                                      lambda msg: self.landed_states.append((now(), msg.landed_state)))]

    def first_reached(self):
        """[(seq, time)] in the order each seq was first reported."""
        seen = {}
        for t, seq in list(self.reached):
            seen.setdefault(seq, t)
        return sorted(seen.items(), key=lambda item: item[1])

    def landed_at(self, since):
        """The first time the vehicle is on the ground after it was in the air, after `since`; else None."""
        airborne = False
        for t, state in list(self.landed_states):
            if t < since:
                continue
            if state in (ExtendedState.LANDED_STATE_IN_AIR, ExtendedState.LANDED_STATE_TAKEOFF,
                         ExtendedState.LANDED_STATE_LANDING):
                airborne = True
            elif airborne and state == ExtendedState.LANDED_STATE_ON_GROUND:
                return t
        return None

    def push_mission(self, timeout_s):
        """mission/push of the whole box; mavros refuses a push while its own pull after the
        connection runs (success false), so retry within timeout_s."""
        push = rospy.ServiceProxy('mavros/mission/push', WaypointPush)
        deadline, answers = now() + timeout_s, []
        while now() < deadline:
            answer = self.call_service(push, 20.0, start_index=0, waypoints=mission_box())
            answers.append((answer.success, answer.wp_transfered))
            if answer.success:
                self.assertEqual(answer.wp_transfered, len(MISSION_BOX), 'mission/push: %r' % answers)
                return
            self.pause(1.0)
        self.fail('mission/push of %d items not accepted within %.0f s: answers %r'
                  % (len(MISSION_BOX), timeout_s, answers))

    def test_mission_box(self):
        vehicle = Vehicle('mavros')
        self.wait_for_connected(vehicle, 30.0)
        self.push_mission(30.0)
        self.until_accepted(vehicle, 'mode AUTO.MISSION', lambda: self.set_mode(vehicle, 'AUTO.MISSION'),
                            lambda: vehicle.state.mode == 'AUTO.MISSION', READY_S)
        armed_s = self.until_accepted(vehicle, 'arming in AUTO.MISSION', lambda: self.set_arm(vehicle, True).success,
                                      lambda: vehicle.state.armed, READY_S)

        landed_lo, landed_hi = bounds(LANDED_S)
        self.wait_until(lambda: self.landed_at(armed_s) is not None, landed_hi + 1.0,
                        'landing at the end of the mission (items reached: %r)' % self.first_reached(), [vehicle])
        landed_s = self.landed_at(armed_s)
        reached = self.first_reached()
        self.assertEqual([seq for seq, _ in reached][:len(REACHED_S)], list(range(len(REACHED_S))),
                         'items 0..%d reached in order: %r' % (len(REACHED_S) - 1, reached))
        for (seq, t), runs in zip(reached, REACHED_S):
            lo, hi = bounds(runs)
            self.assertTrue(lo <= t - armed_s <= hi, 'item %d reached %.2f s after the arm; PX4 %.2f-%.2f s, '
                            'allowed %.2f-%.2f s' % (seq, t - armed_s, runs[0], runs[1], lo, hi))
            rospy.loginfo('item %d reached %.2f s after the arm (PX4 %.2f-%.2f s)', seq, t - armed_s, *runs)
        self.assertTrue(landed_lo <= landed_s - armed_s <= landed_hi, 'landed %.2f s after the arm; PX4 %.2f-%.2f s, '
                        'allowed %.2f-%.2f s' % (landed_s - armed_s, LANDED_S[0], LANDED_S[1], landed_lo, landed_hi))
        rospy.loginfo('landed %.2f s after the arm (PX4 %.2f-%.2f s)', landed_s - armed_s, *LANDED_S)
        # PX4 disarms 0.02-0.41 s after it lands, and the disarmed HEARTBEAT can come before the
        # EXTENDED_SYS_STATE that says so: the flight ends a report period (and a delivery) before the landing seen
        flight = [(t, s.mode, s.armed) for t, s in vehicle.states_stamped_since(armed_s)
                  if t < landed_s - LANDED_SEEN_LATE_S]
        self.assertTrue(flight, 'no state between the arm and the landing')
        self.assertTrue(all(mode == 'AUTO.MISSION' and armed for _, mode, armed in flight),
                        'AUTO.MISSION and armed from the arm to the landing: %r'
                        % [(round(t - armed_s, 2), mode, armed) for t, mode, armed in flight])

        disarm_by = LANDED_TO_DISARMED_S * (1.0 + WIDEN) + STATE_PERIOD_S + self.late_s()
        self.wait_until(lambda: not vehicle.state.armed, disarm_by + 1.0, 'disarm after the landing', [vehicle])
        disarmed_s = next(t for t, s in vehicle.states_since(armed_s) if not s.armed)
        self.assertLessEqual(disarmed_s - landed_s, disarm_by, 'disarmed %.2f s after the landing; PX4 %.2f s at most, '
                             'allowed %.2f s with a state period and a busy machine'
                             % (disarmed_s - landed_s, LANDED_TO_DISARMED_S, disarm_by))
        rospy.loginfo('disarmed %.2f s after the landing (PX4 0.02-%.2f s)', disarmed_s - landed_s,
                      LANDED_TO_DISARMED_S)


if __name__ == '__main__':
    rospy.init_node('test_mission')
    rostest.rosrun(PKG, 'mission', MissionTest)
