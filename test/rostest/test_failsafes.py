#!/usr/bin/env python3
"""PX4's failsafes under the tutorial's node (offb_node.py with respect_pilot:=true, flying OFFBOARD at 2 m), each
caused through MAVLink by the test kit's ground station (offboard_py.testing.Failures), so that the same
scenario means the same on real PX4 SITL (the cross-stack tier, offboard_py.testing.cross_stack). Each asserts
PX4's reaction (src/modules/commander/failsafe/failsafe.cpp and framework.cpp: the action, its Hold of
COM_FAIL_ACT_T first where the action allows the pilot to take over) and that the node survives it: still
running, it logged the takeover and asked for OFFBOARD no more. The case is the test's ~case parameter
(failsafe_<case>.test)."""

import json
import os

import rosnode
import rospy
import rostest
from mavros_msgs.msg import ExtendedState, Waypoint
from mavros_msgs.srv import WaypointPush

from offboard_py.dialect import mavlink
from offboard_py.testing import Failures, OffboardTestCase, RosoutRecorder, Vehicle, now
from offboard_py.testing.reference import load, px4_figure, px4_param, px4_rate_hz, px4_rc_loss_seen_s

PKG = 'offboard_py'
NODE = '/offb_node_py'
# PX4 SITL's figures, from reference/ (its parameters as recorded, its census, its source)
FAIL_ACT_S = px4_param('COM_FAIL_ACT_T')        # the Hold before a delayed action
STATE_PERIOD_S = 1.0 / px4_rate_hz('HEARTBEAT')  # mavros/state follows PX4's HEARTBEAT
DL_LOSS_S = px4_param('COM_DL_LOSS_T')
GCS_TIMEOUT_S = px4_figure('mavlink', 'gcs_heartbeat_timeout_s')  # telemetry_status keeps a GCS HEARTBEAT so long
NOAID_TIMEOUT_S = px4_param('EKF2_NOAID_TOUT') / 1e6  # EKF2 keeps a position this long without GPS (us)
OF_LOSS_S = px4_param('COM_OF_LOSS_T')
CHECK_S = px4_figure('commander', 'check_period_s')  # the commander's health checks, and its failsafe flags
RC_LOSS_SEEN_S = px4_rc_loss_seen_s()
BATTERY_OFF = load('px4-sitl-battery-off.json')['seconds_from_the_injection']  # one run of real PX4 SITL
BATTERY_HOLD_S = next(row['t'] for row in BATTERY_OFF
                      if row.get('text', '').startswith('Failsafe activated: entering Hold'))
BATTERY_LAND_S = next(row['t'] for row in BATTERY_OFF
                      if row['message'] == 'HEARTBEAT' and row.get('mode') == 'AUTO.LAND')
RECORDED_WIDEN = 0.25  # of a time of the one recorded run
FENCE_RADIUS_M = 5.0
# where each case appends its figures (one JSON line), for setting the simulated PX4's beside real PX4's
FIGURES_ENV = 'OFFBOARD_PY_FAILSAFE_FIGURES'


def stamp(state):
    return state.header.stamp.to_sec()


class FailsafeCase(OffboardTestCase):
    """The node flying OFFBOARD at 2 m with the ground station on, then one failure."""

    def setUp(self):
        self.vehicle = Vehicle('mavros')
        self.log = RosoutRecorder(NODE)
        self.failures = Failures(rospy.get_param('~instance'))
        self.failures.connected(30.0)

    def tearDown(self):
        self.failures.close()

    def fly(self, z_m=2.0):
        self.wait_for_offboard_and_armed(self.vehicle, 90.0)
        self.wait_for_altitude(self.vehicle, z_m, 0.2, 30.0)

    def assert_node_respected_the_failsafe(self, start):
        """Running, it saw the pilot (the failsafe) take over, and the vehicle, armed, never went back to
        OFFBOARD (disarmed, PX4 shows the user's mode again: OFFBOARD, the node's last choice)."""
        self.assertIn(NODE, rosnode.get_node_names(), 'the node is gone')
        self.assertTrue(any(line.startswith('Pilot took over') for line in self.log.lines),
                        'the node never logged the takeover: %s' % self.log.lines)
        armed = [s.mode for _, s in self.vehicle.states_since(start) if s.armed]
        first_out = next(i for i, mode in enumerate(armed) if mode != 'OFFBOARD')
        self.assertNotIn('OFFBOARD', armed[first_out:], 'back in OFFBOARD after the failsafe: %s' % armed)

    def disarmed_after(self, start):
        return next(stamp(s) for _, s in self.vehicle.states_since(start) if not s.armed) - start

    def wait_landed_and_disarmed(self, timeout_s=60.0):
        self.wait_for_armed(self.vehicle, False, timeout_s)
        self.assertEqual(self.vehicle.extended_state.landed_state, ExtendedState.LANDED_STATE_ON_GROUND)

    def record(self, **figures):
        """The case's figures (s after the failure, m): logged, and appended to $OFFBOARD_PY_FAILSAFE_FIGURES."""
        figures = dict(case=rospy.get_param('~case'), **{k: round(v, 2) for k, v in figures.items()})
        rospy.loginfo('failsafe figures: %s', figures)
        path = os.environ.get(FIGURES_ENV)
        if path:
            with open(path, 'a') as f:
                f.write(json.dumps(figures) + '\n')

    def seconds_to(self, mode, start, timeout_s):
        """Seconds from `start` to the first state in `mode`, by its stamp (the bridge's clock when the
        HEARTBEAT came, as mavros stamps it), not when this node read it."""
        self.wait_for_mode(self.vehicle, mode, timeout_s, since=start)
        return next(stamp(s) for _, s in self.vehicle.states_since(start) if s.mode == mode) - start


class Battery(FailsafeCase):

    def test_battery_off_holds_then_lands(self):
        """BatterySimulator's OFF (empty cells): CRITICAL 2.6 s later: Hold for COM_FAIL_ACT_T (COM_LOW_BAT_ACT 3
        returns at critical), EMERGENCY meanwhile: Land when the Hold ends (PX4 SITL, reference/
        px4-sitl-battery-off.json: Hold at 2.58 s, AUTO.LAND at 8.11 s in HEARTBEAT, one run)."""
        self.fly()
        start, said_since = now(), self.failures.now()  # ROS time; the ground station's clock
        self.assertEqual(self.failures.battery_off(), 0)
        held = self.seconds_to('AUTO.LOITER', start, 10.0)
        landing = self.seconds_to('AUTO.LAND', start, 15.0)
        # a busy machine can only make them late: late_s() widens the upper bounds alone
        said = 'Hold %.2f s after, PX4 %.2f s' % (held, BATTERY_HOLD_S)
        self.assertGreaterEqual(held, BATTERY_HOLD_S * (1 - RECORDED_WIDEN) - STATE_PERIOD_S, said)
        self.assertLessEqual(held, BATTERY_HOLD_S * (1 + RECORDED_WIDEN) + STATE_PERIOD_S + self.late_s(), said)
        said = 'AUTO.LAND %.2f s after, PX4 %.2f s' % (landing, BATTERY_LAND_S)
        self.assertGreaterEqual(landing, BATTERY_LAND_S * (1 - RECORDED_WIDEN), said)
        self.assertLessEqual(landing, BATTERY_LAND_S * (1 + RECORDED_WIDEN) + self.late_s(), said)
        self.wait_landed_and_disarmed()
        self.record(hold_s=held, land_s=landing, disarmed_s=self.disarmed_after(start))
        self.assert_node_respected_the_failsafe(start)
        said = [text for _, _, text in self.failures.texts(said_since)]
        for text in ('Low battery', 'Failsafe activated: entering Hold for 5 seconds', 'Emergency battery level',
                     'Failsafe activated'):
            self.assertIn(text, said)


class DataLink(FailsafeCase):

    def test_ground_station_lost_holds_then_returns(self):
        """NAV_DLL_ACT 2 (Return; PX4 SITL has 0, nothing): no GCS HEARTBEAT for COM_DL_LOSS_T (counted from
        telemetry_status, which keeps one for HEARTBEAT_TIMEOUT_US), Hold for COM_FAIL_ACT_T, then Return and land."""
        self.pause(GCS_TIMEOUT_S)  # PX4 counts the ground station at its next telemetry_status check
        self.assertEqual(self.failures.set_param('NAV_DLL_ACT', 2), 2)
        self.fly()
        start = now()  # before the cut: however late this node reads the clock, `held` is not short
        self.failures.cut_data_link()
        held = self.seconds_to('AUTO.LOITER', start, DL_LOSS_S + GCS_TIMEOUT_S + 5.0)
        returning = self.seconds_to('AUTO.RTL', start, FAIL_ACT_S + 5.0)
        self.assertGreaterEqual(held, DL_LOSS_S, 'held %.2f s after the last HEARTBEAT' % held)
        self.assertLessEqual(held, DL_LOSS_S + GCS_TIMEOUT_S + STATE_PERIOD_S + 0.5 + self.late_s())
        self.assertAlmostEqual(returning - held, FAIL_ACT_S, delta=STATE_PERIOD_S + 0.3 + self.late_s())
        self.wait_landed_and_disarmed()
        self.record(hold_s=held, rtl_s=returning, disarmed_s=self.disarmed_after(start))
        self.assert_node_respected_the_failsafe(start)


class Geofence(FailsafeCase):

    def test_leaving_the_fence_holds_inside_reach(self):
        """A 5 m circle around home uploaded through mavros's geofence/push (the mission protocol with mission_type
        FENCE), as a ROS user uploads one; the node flies to 10 m north: GF_ACTION 2 (Hold), where the breach was
        seen; the node leaves it there."""
        lat, lon, _ = self.failures.home()
        circle = Waypoint(frame=mavlink.MAV_FRAME_GLOBAL, command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
                          autocontinue=True, param1=FENCE_RADIUS_M, x_lat=lat, y_long=lon)
        rospy.wait_for_service('mavros/geofence/push', 30.0)
        pushed = rospy.ServiceProxy('mavros/geofence/push', WaypointPush)(start_index=0, waypoints=[circle])
        self.assertEqual((pushed.success, pushed.wp_transfered), (True, 1), 'geofence/push: %s' % pushed)
        start = now()
        self.wait_for_offboard_and_armed(self.vehicle, 90.0)
        self.wait_for_mode(self.vehicle, 'AUTO.LOITER', 30.0)
        self.failures.wait_text('Geofence: approaching or outside geofence', 5.0)
        self.pause(12.0)  # braking from cruise overshoots; the Hold flies back to the breach point
        north = self.vehicle.pose.pose.position.y
        self.assertLess(abs(north - FENCE_RADIUS_M), 2.5, 'holds %.1f m north, the fence at %.0f m' % (
            north, FENCE_RADIUS_M))
        self.assertEqual(self.vehicle.state.mode, 'AUTO.LOITER')
        self.record(hold_north_m=north)
        self.assert_node_respected_the_failsafe(start)


class Gps(FailsafeCase):

    def test_gps_off_falls_back_to_altitude(self):
        """GPS off (SimulatorMavlink stops it): after EKF2_NOAID_TOUT the position is invalid, the node's position
        setpoints no offboard signal; COM_OBL_RC_ACT 0 means Position, which cannot run: Altitude."""
        self.fly()
        start = now()
        self.assertEqual(self.failures.gps_off(), 0)
        took = self.seconds_to('ALTCTL', start, NOAID_TIMEOUT_S + 5.0)
        self.assertGreaterEqual(took, NOAID_TIMEOUT_S)
        self.assertLessEqual(took, NOAID_TIMEOUT_S + STATE_PERIOD_S + 0.5 + self.late_s())
        self.assert_holds(self.vehicle, 2.0, 0.3, 3.0)
        self.record(altctl_s=took)
        self.assert_node_respected_the_failsafe(start)


class ManualControl(FailsafeCase):

    def test_joystick_lost_holds_then_returns(self):
        """A ground station's joystick (MANUAL_CONTROL; PX4 SITL's COM_RC_IN_MODE 1) there at arming and then
        lost: after COM_RC_LOSS_T, NAV_RCL_ACT 2: Hold for COM_FAIL_ACT_T, then Return and land."""
        self.failures.start_joystick()
        self.fly()
        start = now()
        self.failures.lose_rc()
        held = self.seconds_to('AUTO.LOITER', start, 5.0)
        returning = self.seconds_to('AUTO.RTL', start, FAIL_ACT_S + 5.0)
        self.assertLessEqual(held, RC_LOSS_SEEN_S + CHECK_S + STATE_PERIOD_S + 0.3 + self.late_s(),
                             'COM_RC_LOSS_T (seen at %.1f s): held after %.2f s' % (RC_LOSS_SEEN_S, held))
        self.assertAlmostEqual(returning - held, FAIL_ACT_S, delta=STATE_PERIOD_S + 0.3 + self.late_s())
        self.wait_landed_and_disarmed()
        self.record(hold_s=held, rtl_s=returning, disarmed_s=self.disarmed_after(start))
        self.assert_node_respected_the_failsafe(start)


class OffboardLoss(FailsafeCase):
    """The node killed: COM_OBL_RC_ACT (~obl_act) decides, with the ground station's joystick there (~joystick);
    without it, its manual choices (Position, Altitude, Stabilized) fall to NAV_RCL_ACT (2: Return). A mode
    fallback is not delayed (Failsafe::checkModeFallback: takeover Always)."""

    WITH_MANUAL_CONTROL = {0: 'POSCTL', 1: 'ALTCTL', 2: 'STABILIZED', 3: 'AUTO.RTL', 4: 'AUTO.LAND', 5: 'AUTO.LOITER'}

    def test_offboard_loss_takes_com_obl_rc_act(self):
        obl_act, joystick = rospy.get_param('~obl_act'), rospy.get_param('~joystick')
        expected = self.WITH_MANUAL_CONTROL[obl_act] if joystick or obl_act > 2 else 'AUTO.RTL'
        self.assertEqual(self.failures.set_param('COM_OBL_RC_ACT', obl_act), obl_act)
        if joystick:
            self.failures.start_joystick()
        self.fly()
        rosnode.kill_nodes([NODE])
        self.wait_until(lambda: self.vehicle.state.mode != 'OFFBOARD', 5.0, 'the offboard-loss failsafe',
                        [self.vehicle])
        last = self.vehicle.setpoints[-1]
        left = next(t for t, s in self.vehicle.states_since(last) if s.mode != 'OFFBOARD')
        self.assertEqual(self.vehicle.state.mode, expected)
        self.assertLessEqual(left - last, OF_LOSS_S + CHECK_S + STATE_PERIOD_S + 0.3 + self.late_s(),
                             'COM_OF_LOSS_T %.1f s: left OFFBOARD %.2f s after the last setpoint' % (OF_LOSS_S,
                                                                                                   left - last))
        self.record(obl_act=obl_act, joystick=int(bool(joystick)), left_offboard_s=left - last)


CASES = {'battery': Battery, 'data_link': DataLink, 'geofence': Geofence, 'gps': Gps, 'rc': ManualControl,
         'offboard': OffboardLoss}

if __name__ == '__main__':
    rospy.init_node('test_failsafes')
    case = rospy.get_param('~case')
    rostest.rosrun(PKG, 'failsafe_' + case, CASES[case])
