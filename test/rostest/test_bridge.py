#!/usr/bin/env python3
"""The bridge's mavros API: names, types and semantics, against the simulated PX4 and a silent FCU."""

import math
import os
import signal
import threading
import time

import rospkg
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, Quaternion, Twist, TwistStamped
from mavros_msgs.msg import (Altitude, AttitudeTarget, EstimatorStatus, GlobalPositionTarget, HomePosition, Mavlink,
                             PositionTarget, StatusText, Thrust, TimesyncStatus, VFR_HUD, Waypoint, WaypointList)
from mavros_msgs.srv import (CommandInt, CommandLong, MessageInterval, ParamGet, ParamPull, ParamPush, ParamSet,
                             ParamSetRequest, StreamRate, WaypointClear, WaypointPush, WaypointSetCurrent)
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState, FluidPressure, Imu, MagneticField, NavSatFix, Temperature, TimeReference
from std_msgs.msg import Float64, UInt32
from tf2_msgs.msg import TFMessage

from offboard_py import px4_modes
from offboard_py.dialect import mavlink
from offboard_py.sim.mavlink.sensor_messages import BARO_RATE_HZ, MAG_RATE_HZ
from offboard_py.testing.mavlink_listener import MavlinkListener
from offboard_py.testing.processes import OutputProcess
from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle, yaw_of
from offboard_py.bridge.mavlink_passthrough import frame_to_msg
from offboard_py.testing.mavros_typemasks import IGNORE_ACCELERATION, IGNORE_POSITION, POSITION_AND_YAW, VELOCITY_ONLY

PKG = 'offboard_py'
VELOCITY_YAW_RATE = IGNORE_POSITION | IGNORE_ACCELERATION | mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE
START = time.time()  # this scenario runs in real time (bridge.test), where ROS time is the wall clock
# the modes mavros 1.21 names that PX4 main (02e73e3b6f) has; RATTITUDE is mavros's only, PX4 refuses it
PX4_MODES = ('MANUAL', 'ALTCTL', 'POSCTL', 'ACRO', 'STABILIZED', 'OFFBOARD', 'AUTO.TAKEOFF',
             'AUTO.LOITER', 'AUTO.MISSION', 'AUTO.RTL', 'AUTO.LAND')


class SilentFcu(MavlinkListener):
    """A fake PX4 for the silent bridge: HEARTBEATs and what the test asks, never a COMMAND_ACK."""

    def __init__(self, port, bridge_port):
        super().__init__(port, bridge_port)
        self.beating = True
        threading.Thread(target=self._beat, daemon=True).start()

    def _beat(self):
        hold_disarmed = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_AUTO_ENABLED
                         | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED)
        while self.running:
            if self.beating:
                self.send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4,
                                                    hold_disarmed, px4_modes.encode('AUTO.LOITER'),
                                                    mavlink.MAV_STATE_STANDBY))
            time.sleep(0.5)


def read_diagnostics_echo(text):
    """[(name, level, message, [keys])] from `rostopic echo` of a DiagnosticArray."""
    statuses = []
    for line in text.splitlines():
        field, _, value = line.strip().partition(': ')
        if field == 'level':
            statuses.append([None, int(value), None, []])
        elif field in ('name', 'message') and statuses:
            statuses[-1][0 if field == 'name' else 2] = value.strip('"')
        elif field == 'key' and statuses:
            statuses[-1][3].append(value.strip('"'))
    return [tuple(status) for status in statuses]


class BridgeTest(OffboardTestCase):

    @classmethod
    def setUpClass(cls):
        cls.fcu = SilentFcu(rospy.get_param('~silent_fcu_port'), rospy.get_param('~silent_bridge_port'))
        cls.sim = Vehicle('mavros')
        cls.silent = Vehicle('silent/mavros')

    def test_01_connects_fast_and_state_fields(self):
        self.wait_for_connected(self.sim, 15.0)
        first = next(t for t, s in self.sim.states if s.connected)
        self.assertLessEqual(first - START, 3.0, 'connected %.1f s after the nodes started' % (first - START))
        state = self.sim.state
        self.assertEqual(state.mode, 'AUTO.LOITER')
        self.assertTrue(state.guided, 'AUTO modes set GUIDED')
        self.assertFalse(state.armed)
        # PX4 reports UNINIT until its pre-flight checks pass (about 5 s after boot), then STANDBY
        self.assertIn(state.system_status, (mavlink.MAV_STATE_UNINIT, mavlink.MAV_STATE_STANDBY))
        self.wait_until(lambda: self.sim.state.system_status == mavlink.MAV_STATE_STANDBY, 10.0,
                        'system_status STANDBY once the checks pass', [self.sim])

    def test_01b_param_set_right_after_connection(self):
        """As PX4's posctl integration test: set COM_RCL_EXCEPT as soon as the topics are up, before the
        bridge's own pull 10 s after connecting (mavros answers false there). On a simulated PX4 and a bridge
        of this test's own, started here, so the test holds wherever it runs in the order."""
        bridge_port, fcu_port, gcs_port, gcs_remote = (rospy.get_param('~early_port_%d' % k) for k in range(4))
        sim = OutputProcess(['rosrun', PKG, 'sim_px4.py', '--speed', '1', '--local-port', str(fcu_port), '--remote-port',
                             str(bridge_port), '--gcs-port', str(gcs_port), '--gcs-remote-port', str(gcs_remote)])
        bridge = OutputProcess(['rosrun', PKG, 'mavros_bridge.py', '__name:=mavros', '__ns:=early',
                                '_fcu_url:=udp://127.0.0.1:%d@127.0.0.1:%d' % (bridge_port, fcu_port),
                                '_gcs_url:='])
        try:
            early = Vehicle('early/mavros')
            self.wait_for_connected(early, 20.0)
            first = next(t for t, s in early.states if s.connected)
            rospy.wait_for_service('early/mavros/param/set', 5.0)
            req = ParamSetRequest(param_id='COM_RCL_EXCEPT')
            req.value.integer = 4
            res = rospy.ServiceProxy('early/mavros/param/set', ParamSet)(req)
            done = time.time()  # ROS time, as the Vehicle's state stamps
            self.assertLess(done - first, 10.0, 'the set came %.1f s after connecting, after the pull'
                            % (done - first))
            self.assertTrue(res.success and res.value.integer == 4, 'set before the pull: %s' % res)
            got = rospy.ServiceProxy('early/mavros/param/get', ParamGet)(param_id='MPC_XY_VEL_MAX')
            self.assertTrue(got.success and got.value.real == 12.0, 'get before the pull: %s' % got)
        finally:
            bridge.stop(signal.SIGINT, timeout_s=10.0)
            sim.stop(signal.SIGINT, timeout_s=10.0)

    def test_02_mode_strings_for_px4_modes(self):
        self.wait_for_connected(self.sim, 15.0)
        for mode in PX4_MODES:
            self.assertTrue(self.set_mode(self.sim, mode))
            self.wait_for_mode(self.sim, mode, 4.0)
        self.assertTrue(self.set_mode(self.sim, 'RATTITUDE'), 'mavros has the name, so it is sent')
        time.sleep(2.5)  # two HEARTBEATs: PX4 refused it ("Unsupported main mode"), nothing changed
        self.assertEqual(self.sim.state.mode, PX4_MODES[-1])
        self.assertTrue(self.set_mode(self.sim, 'auto.loiter'), 'mode strings are upper-cased')
        self.wait_for_mode(self.sim, 'AUTO.LOITER', 4.0)
        self.assertTrue(self.set_mode(self.sim, str(px4_modes.encode('AUTO.MISSION'))),
                        'a number is taken as custom_mode')
        self.wait_for_mode(self.sim, 'AUTO.MISSION', 4.0)
        self.assertFalse(self.set_mode(self.sim, 'NOT_A_MODE'), 'unknown mode: mode_sent=false')
        self.set_mode(self.sim, 'AUTO.LOITER')

    def test_03_arming_ack_semantics(self):
        self.wait_for_connected(self.sim, 15.0)
        self.wait_until(lambda: time.time() - START > 6.0, 10.0, 'the FCU to be ready')
        self.set_mode(self.sim, 'OFFBOARD')
        self.wait_for_mode(self.sim, 'OFFBOARD', 4.0)
        refused = self.set_arm(self.sim, True)
        self.assertEqual((refused.success, refused.result), (False, mavlink.MAV_RESULT_TEMPORARILY_REJECTED),
                         'no offboard signal: TEMPORARILY_REJECTED')
        self.set_mode(self.sim, 'AUTO.LOITER')
        self.wait_for_mode(self.sim, 'AUTO.LOITER', 4.0)
        armed = self.set_arm(self.sim, True)
        self.assertEqual((armed.success, armed.result), (True, mavlink.MAV_RESULT_ACCEPTED))
        self.wait_for_armed(self.sim, True, 3.0)
        disarmed = self.set_arm(self.sim, False)
        self.assertEqual((disarmed.success, disarmed.result), (True, mavlink.MAV_RESULT_ACCEPTED))

    def test_04_arming_timeout_and_busy_against_silent_fcu(self):
        self.wait_for_connected(self.silent, 10.0)
        results = []

        def call():
            try:
                results.append(self.silent.arming_srv(value=True))
            except rospy.ServiceException as err:
                results.append(err)
        self.silent.arming_srv.wait_for_service(5.0)
        first = threading.Thread(target=call)
        first.start()
        time.sleep(0.3)
        call()  # the same command while the first waits: the service call fails
        first.join(10.0)
        errors = [r for r in results if isinstance(r, Exception)]
        answers = [r for r in results if not isinstance(r, Exception)]
        self.assertEqual(len(errors), 1, 'the second arming call must fail: %s' % results)
        self.assertEqual(len(answers), 1)
        self.assertEqual((answers[0].success, answers[0].result), (False, mavlink.MAV_RESULT_FAILED),
                         'no ACK: success=false, result=FAILED')
        cmds = [m for m in self.fcu.of_type('COMMAND_LONG') if m.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM]
        self.assertTrue(cmds and cmds[0].param1 == 1.0 and cmds[0].confirmation == 1)

    def setpoints_at_fcu_after(self, before, name='SET_POSITION_TARGET_LOCAL_NED'):
        """The messages `name` the FCU got after the first `before`, once one came."""
        # the silent FCU is this process, on wall time: at 5x, 5 s of ROS time is 1 s of it
        self.wait_until(lambda: len(self.fcu.of_type(name)) > before, 5.0, 'a %s at the FCU' % name, min_wall_s=5.0)
        time.sleep(0.3)  # anything sent after it would have arrived by now
        return self.fcu.of_type(name)[before:]

    def publish_until_at_fcu(self, pub, msg, name, timeout_s=10.0):
        """Publish msg every 0.2 s (wall) until the FCU gets a `name` more; then let the stragglers land."""
        before, deadline = len(self.fcu.of_type(name)), time.monotonic() + timeout_s
        while len(self.fcu.of_type(name)) == before:
            if time.monotonic() > deadline:
                self.fail('no %s at the FCU within %.0f s of publishing on %s every 0.2 s'
                          % (name, timeout_s, pub.resolved_name))
            pub.publish(msg)
            time.sleep(0.2)
        time.sleep(0.3)

    def sent_to_fcu(self, topic, data_class, messages, name, tries=4, prepare=None):
        """Publish `messages` on the silent bridge's `topic`; what the FCU got as `name`. A first message on a
        fresh publisher can be lost although the connection is counted (rospy; seen once on a busy machine
        under two busy loops): published again, up to `tries` times, a wall second apart, until one comes;
        prepare() before each (fresh stamps, a paired message first)."""
        pub = rospy.Publisher(topic, data_class, queue_size=10)
        try:
            self.wait_until(lambda: pub.get_num_connections() > 0, 5.0, 'the bridge subscribing to %s' % topic)
            for _ in range(tries - 1):
                if prepare is not None:
                    prepare()
                before = len(self.fcu.of_type(name))
                for msg in messages:
                    pub.publish(msg)
                deadline = time.monotonic() + 1.0
                while len(self.fcu.of_type(name)) == before and time.monotonic() < deadline:
                    time.sleep(0.02)
                if len(self.fcu.of_type(name)) > before:
                    time.sleep(0.3)  # anything sent after it would have arrived by now
                    return self.fcu.of_type(name)[before:]
            if prepare is not None:
                prepare()
            before = len(self.fcu.of_type(name))
            for msg in messages:
                pub.publish(msg)
            return self.setpoints_at_fcu_after(before, name)
        finally:
            pub.unregister()

    def test_05c_every_setpoint_and_outgoing_topic_reaches_the_fcu(self):
        """mavros's other input topics, through the node to the FCU as the MAVLink they stand for."""
        self.wait_for_connected(self.silent, 10.0)
        ns = 'silent/mavros/'
        twist = Twist()
        twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.z = 1.0, 2.0, 3.0, 0.5
        for topic, cls, msg in (('setpoint_velocity/cmd_vel_unstamped', Twist, twist),
                                ('setpoint_velocity/cmd_vel', TwistStamped, TwistStamped(twist=twist))):
            got = self.sent_to_fcu(ns + topic, cls, [msg], 'SET_POSITION_TARGET_LOCAL_NED')
            self.assertEqual(len(got), 1, topic)
            m = got[0]
            self.assertEqual((m.type_mask, m.vx, m.vy, m.vz), (VELOCITY_YAW_RATE, 2.0, 1.0, -3.0), topic + ': ENU -> NED')
            self.assertAlmostEqual(m.yaw_rate, -0.5, places=5, msg=topic + ': FLU yaw rate -> FRD')
        # setpoint_raw/attitude: level, facing east (ENU yaw 0) is NED yaw pi/2; thrust as given
        att = AttitudeTarget(type_mask=AttitudeTarget.IGNORE_ROLL_RATE | AttitudeTarget.IGNORE_PITCH_RATE
                             | AttitudeTarget.IGNORE_YAW_RATE, thrust=0.6)
        att.orientation.w = 1.0
        got = self.sent_to_fcu(ns + 'setpoint_raw/attitude', AttitudeTarget, [att], 'SET_ATTITUDE_TARGET')
        self.assertEqual(len(got), 1)
        self.assertAlmostEqual(got[0].thrust, 0.6, places=5)
        w, x, y, z = got[0].q
        self.assertAlmostEqual(math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)), math.pi / 2, places=4)
        # setpoint_attitude/cmd_vel (px4_config.yaml's use_quaternion false) paired with setpoint_attitude/thrust:
        # body rates through mavros's ENU <-> NED swap, the attitude ignored
        thrust_pub = rospy.Publisher(ns + 'setpoint_attitude/thrust', Thrust, queue_size=10)
        try:
            self.wait_until(lambda: thrust_pub.get_num_connections() > 0, 5.0, 'the bridge subscribing to thrust')
            thrust, cmd = Thrust(thrust=0.4), TwistStamped()
            cmd.twist.angular.x, cmd.twist.angular.y, cmd.twist.angular.z = 0.1, 0.2, 0.3

            def pair():  # the thrust first, then the rates 0.2 s later: within the bridge's 0.5 s pairing window
                thrust.header.stamp = rospy.Time.now()
                thrust_pub.publish(thrust)
                time.sleep(0.2)
                cmd.header.stamp = rospy.Time.now()
            got = self.sent_to_fcu(ns + 'setpoint_attitude/cmd_vel', TwistStamped, [cmd], 'SET_ATTITUDE_TARGET',
                                   prepare=pair)
        finally:
            thrust_pub.unregister()
        self.assertEqual(len(got), 1)
        self.assertAlmostEqual(got[0].thrust, 0.4, places=5)
        self.assertEqual(got[0].type_mask, AttitudeTarget.IGNORE_ATTITUDE)
        rates = (got[0].body_roll_rate, got[0].body_pitch_rate, got[0].body_yaw_rate)
        for value, expected in zip(rates, (0.2, 0.1, -0.3)):
            self.assertAlmostEqual(value, expected, places=5, msg='body rates %s, mavros sends (0.2, 0.1, -0.3)'
                                   % (rates,))
        # setpoint_raw/global: position only, AMSL altitude as given
        target = GlobalPositionTarget(coordinate_frame=GlobalPositionTarget.FRAME_GLOBAL_INT,
                                      type_mask=0xFF8, latitude=47.3978, longitude=8.5456, altitude=510.0)
        got = self.sent_to_fcu(ns + 'setpoint_raw/global', GlobalPositionTarget, [target],
                               'SET_POSITION_TARGET_GLOBAL_INT')
        self.assertEqual(len(got), 1)
        self.assertEqual((got[0].lat_int, got[0].lon_int, got[0].alt), (473978000, 85456000, 510.0))
        # statustext/send
        got = self.sent_to_fcu(ns + 'statustext/send', StatusText,
                               [StatusText(severity=StatusText.WARNING, text='hello from the test')], 'STATUSTEXT')
        self.assertEqual((got[0].severity, got[0].text), (StatusText.WARNING, 'hello from the test'))
        # /mavlink/to (the node's namespace): a raw frame goes out as the frame it describes
        frame = self.fcu.mav.param_request_read_encode(1, 1, b'MPC_XY_CRUISE', -1).pack(self.fcu.mav)
        got = self.sent_to_fcu('silent/mavlink/to', Mavlink, [frame_to_msg(bytearray(frame), rospy.Time.now())],
                               'PARAM_REQUEST_READ')
        self.assertEqual(got[0].param_id, 'MPC_XY_CRUISE')

    def test_05_setpoint_enu_arrives_as_ned(self):
        self.wait_for_connected(self.silent, 10.0)
        pub = rospy.Publisher('silent/mavros/setpoint_position/local', PoseStamped, queue_size=10)
        self.wait_until(lambda: pub.get_num_connections() > 0, 5.0, 'the bridge subscribing')
        # a setpoint through first, so that what follows travels a connection known to deliver (one
        # run lost both of its first messages on a fresh one: rospy's, not the conversion under test)
        first = PoseStamped()
        first.pose.orientation.w = 1.0
        self.publish_until_at_fcu(pub, first, 'SET_POSITION_TARGET_LOCAL_NED')
        before = len(self.fcu.of_type('SET_POSITION_TARGET_LOCAL_NED'))
        bad = PoseStamped()
        bad.pose.position.x = float('nan')
        bad.pose.orientation.w = 1.0
        pub.publish(bad)
        sp = PoseStamped()
        sp.pose.position.x, sp.pose.position.y, sp.pose.position.z = 1.0, 2.0, 3.0
        sp.pose.orientation = Quaternion(0.0, 0.0, 0.0, 1.0)  # yaw 0 ENU: facing east
        pub.publish(sp)
        got = self.setpoints_at_fcu_after(before)
        self.assertEqual(len(got), 1, 'the NaN setpoint must not be sent')
        m = got[0]
        self.assertEqual((m.coordinate_frame, m.type_mask), (mavlink.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW))
        self.assertEqual((round(m.x, 6), round(m.y, 6), round(m.z, 6)), (2.0, 1.0, -3.0))
        self.assertAlmostEqual(m.yaw, math.pi / 2, places=5)

    def test_05b_raw_setpoint_nan_only_matters_where_used(self):
        self.wait_for_connected(self.silent, 10.0)
        log = RosoutRecorder('/silent/mavros')
        pub = rospy.Publisher('silent/mavros/setpoint_raw/local', PositionTarget, queue_size=10)
        self.wait_until(lambda: pub.get_num_connections() > 0 and log.sub.get_num_connections() > 0, 5.0,
                        'the bridge subscribing, and /rosout connected')
        velocity_only = VELOCITY_ONLY
        # as test_05: a setpoint through first, so that the pair travels a connection known to deliver (the
        # pair alone, on a fresh one, reached the bridge in none of 5 s once, in an idle fresh-clone run)
        self.publish_until_at_fcu(pub, PositionTarget(coordinate_frame=mavlink.MAV_FRAME_LOCAL_NED,
                                                      type_mask=velocity_only), 'SET_POSITION_TARGET_LOCAL_NED')
        before = len(self.fcu.of_type('SET_POSITION_TARGET_LOCAL_NED'))
        bad = PositionTarget(coordinate_frame=mavlink.MAV_FRAME_LOCAL_NED, type_mask=velocity_only)
        bad.velocity.z = float('nan')
        pub.publish(bad)
        good = PositionTarget(coordinate_frame=mavlink.MAV_FRAME_LOCAL_NED, type_mask=velocity_only)
        good.position.x = good.position.z = good.yaw = float('nan')  # ignored by the mask
        good.velocity.x = 1.0
        pub.publish(good)
        got = self.setpoints_at_fcu_after(before)
        self.assertEqual(len(got), 1, 'the setpoint with a NaN velocity must not be sent')
        m = got[0]
        self.assertEqual((m.type_mask, m.vx, m.vy, m.x, m.z, m.yaw), (velocity_only, 0.0, 1.0, 0.0, 0.0, 0.0))
        self.wait_until(lambda: any('NaN or infinite velocity.z not sent' in line for line in log.lines), 5.0,
                        'the refusal logged, naming the field')

    def test_06_local_pose_is_enu(self):
        self.wait_for_connected(self.silent, 10.0)
        q_ned = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))  # w, x, y, z: yaw 90 deg NED (east)
        for _ in range(5):
            self.fcu.send(self.fcu.mav.attitude_quaternion_encode(0, *q_ned, 0.0, 0.0, 0.0, [0.0] * 4))
            self.fcu.send(self.fcu.mav.local_position_ned_encode(0, 1.0, 2.0, -3.0, 0.5, 0.0, -1.0))
            time.sleep(0.05)
        self.wait_until(lambda: self.silent.pose is not None, 5.0, 'local_position/pose')
        p, q = self.silent.pose.pose.position, self.silent.pose.pose.orientation
        self.assertEqual((round(p.x, 6), round(p.y, 6), round(p.z, 6)), (2.0, 1.0, 3.0))
        self.assertAlmostEqual(yaw_of(q), 0.0, places=5)
        self.assertEqual(self.silent.pose.header.frame_id, 'map')
        v = self.silent.velocity.twist.linear
        self.assertEqual((round(v.x, 6), round(v.y, 6), round(v.z, 6)), (0.0, 0.5, 1.0))

    def test_07_params_float_and_int(self):
        self.wait_for_connected(self.sim, 15.0)
        rospy.wait_for_service('mavros/param/pull', 5.0)
        pull = rospy.ServiceProxy('mavros/param/pull', ParamPull)(force_pull=True)
        self.assertTrue(pull.success)
        self.assertGreaterEqual(pull.param_received, 20)
        get = rospy.ServiceProxy('mavros/param/get', ParamGet)
        put = rospy.ServiceProxy('mavros/param/set', ParamSet)
        # floats travel in value.real, integers in value.integer
        for name, field, default, wanted in (('MIS_TAKEOFF_ALT', 'real', 2.5, 3.0), ('COM_OBL_RC_ACT', 'integer', 0, 4)):
            self.assertEqual(getattr(get(param_id=name).value, field), default, name)
            req = ParamSetRequest(param_id=name)
            setattr(req.value, field, wanted)
            res = put(req)
            self.assertTrue(res.success, name)
            self.assertEqual(getattr(res.value, field), wanted, name)
            self.assertEqual(getattr(get(param_id=name).value, field), wanted, name)
        self.assertFalse(get(param_id='NO_SUCH_PARAM').success)
        # as mavros, the pull and each set mirror the FCU's values into ~param/<ID> (int or float by type)
        mirrored = rospy.get_param('mavros/param', {})
        self.assertGreaterEqual(len(mirrored), pull.param_received - 1, 'all but _HASH_CHECK in ~param')
        self.assertNotIn('_HASH_CHECK', mirrored)
        self.assertEqual((mirrored.get('MIS_TAKEOFF_ALT'), type(mirrored.get('MIS_TAKEOFF_ALT'))), (3.0, float))
        self.assertEqual((mirrored.get('COM_OBL_RC_ACT'), type(mirrored.get('COM_OBL_RC_ACT'))), (4, int))

    def test_08_mission_push_waypoints_clear(self):
        self.wait_for_connected(self.sim, 15.0)
        lists = []
        rospy.Subscriber('mavros/mission/waypoints', WaypointList, lists.append)
        self.wait_until(lambda: lists, 10.0, 'a latched mission/waypoints (also when empty)')
        wps = []
        for i, (lat, lon) in enumerate(((47.3978, 8.5456), (47.3979, 8.5457), (47.3980, 8.5456))):
            wp = Waypoint(frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                          command=mavlink.MAV_CMD_NAV_WAYPOINT if i else mavlink.MAV_CMD_NAV_TAKEOFF,
                          is_current=i == 0, autocontinue=True, x_lat=lat, y_long=lon, z_alt=5.0)
            wps.append(wp)
        rospy.wait_for_service('mavros/mission/push', 5.0)
        res = rospy.ServiceProxy('mavros/mission/push', WaypointPush)(start_index=0, waypoints=wps)
        self.assertTrue(res.success)
        self.assertEqual(res.wp_transfered, 3)
        self.wait_until(lambda: len(lists[-1].waypoints) == 3, 5.0, 'mission/waypoints with 3 items')
        self.assertAlmostEqual(lists[-1].waypoints[1].x_lat, 47.3979, places=6)
        # mission/set_current: the FCU answers with MISSION_CURRENT, and the list follows it
        res = rospy.ServiceProxy('mavros/mission/set_current', WaypointSetCurrent)(wp_seq=2)
        self.assertTrue(res.success, 'mission/set_current 2')
        self.wait_until(lambda: lists[-1].current_seq == 2, 5.0, 'mission/waypoints with current_seq 2')
        self.assertTrue(rospy.ServiceProxy('mavros/mission/clear', WaypointClear)().success)
        self.wait_until(lambda: len(lists[-1].waypoints) == 0, 5.0, 'an empty mission/waypoints after clear')

    def test_08b_command_services_against_the_fcu(self):
        self.wait_for_connected(self.sim, 15.0)
        for name in ('cmd/command', 'cmd/command_int', 'set_message_interval', 'set_stream_rate', 'param/push'):
            rospy.wait_for_service('mavros/' + name, 5.0)
        # cmd/command: PX4 answers REQUEST_MESSAGE(AUTOPILOT_VERSION) with ACK 0, an unknown id with DENIED
        command = rospy.ServiceProxy('mavros/cmd/command', CommandLong)
        res = command(command=mavlink.MAV_CMD_REQUEST_MESSAGE, param1=mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        self.assertEqual((res.success, res.result), (True, mavlink.MAV_RESULT_ACCEPTED))
        res = command(command=mavlink.MAV_CMD_REQUEST_MESSAGE, param1=9999)
        self.assertEqual((res.success, res.result), (False, mavlink.MAV_RESULT_DENIED))
        # cmd/command_int: sent, no ACK awaited (mavros 1.x)
        res = rospy.ServiceProxy('mavros/cmd/command_int', CommandInt)(
            frame=mavlink.MAV_FRAME_GLOBAL_INT, command=mavlink.MAV_CMD_REQUEST_MESSAGE,
            param1=mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        self.assertTrue(res.success)
        # set_message_interval: HOME_POSITION (0.5 Hz on PX4's onboard link) at 5 Hz, then back to the default
        homes = []
        sub = rospy.Subscriber('mavros/home_position/home', HomePosition, lambda m: homes.append(time.monotonic()))
        try:
            interval = rospy.ServiceProxy('mavros/set_message_interval', MessageInterval)
            self.assertTrue(interval(message_id=mavlink.MAVLINK_MSG_ID_HOME_POSITION, message_rate=5.0).success)
            time.sleep(0.5)
            start = time.monotonic()
            time.sleep(3.0)
            rate = len([t for t in homes if t > start]) / 3.0
            self.assertTrue(interval(message_id=mavlink.MAVLINK_MSG_ID_HOME_POSITION, message_rate=0.0).success)
        finally:
            sub.unregister()
        self.assertGreaterEqual(rate, 3.5, 'home_position/home at %.1f Hz after asking for 5 Hz' % rate)
        rospy.ServiceProxy('mavros/set_stream_rate', StreamRate)(stream_id=0, message_rate=10, on_off=True)
        # param/push: every ROS parameter under ~param set on the FCU again, as mavros (a dictionary set
        # at ~param replaces what the pull had mirrored there)
        rospy.set_param('mavros/param', {'MPC_XY_CRUISE': 6.0, 'MPC_XY_VEL_MAX': 12.0})
        res = rospy.ServiceProxy('mavros/param/push', ParamPush)()
        self.assertEqual((res.success, res.param_transfered), (True, 2))
        got = rospy.ServiceProxy('mavros/param/get', ParamGet)(param_id='MPC_XY_CRUISE')
        self.assertAlmostEqual(got.value.real, 6.0, places=5)

    def test_09_home_global_imu_populated(self):
        self.wait_for_connected(self.sim, 15.0)
        home = rospy.wait_for_message('mavros/home_position/home', HomePosition, 20.0)
        self.assertAlmostEqual(home.geo.latitude, 47.397742, places=5)
        # PX4's home is the estimate where it was set: after a fresh start the ground estimate reads
        # local z -0.10 to -0.55 m (reference/px4-sitl-measured.md, Turn 3, section 7), so home is
        # that much above the spawn altitude 488 m (10 % of the span either side)
        low, high = 488.0 + 0.10 - 0.045, 488.0 + 0.55 + 0.045
        self.assertTrue(low <= home.geo.altitude <= high, 'home altitude %.3f m, PX4 SITL: %.2f..%.2f m'
                        % (home.geo.altitude, low, high))
        fix = rospy.wait_for_message('mavros/global_position/global', NavSatFix, 5.0)
        self.assertAlmostEqual(fix.longitude, 8.545594, places=4)
        # SIH's accelerometer on the ground: z mean -9.80 m/s2 (FRD), sd about 0.07 (reference/px4-sitl-
        # measured.md, Turn 3, section 2): the mean of 25 samples, in FLU
        samples = [rospy.wait_for_message('mavros/imu/data', Imu, 5.0).linear_acceleration.z for _ in range(25)]
        self.assertAlmostEqual(sum(samples) / len(samples), 9.80, delta=0.1, msg='FLU: gravity reads +z at rest')

    def test_09b_gcs_url_reaches_a_ground_station_on_14550(self):
        """gcs_url:=udp://@127.0.0.1, as a QGroundControl user writes it: the vehicle's stream
        reaches a ground station bound on 14550 from the bridge's 14555, and the ground
        station's command goes through the bridge to the vehicle and its answer comes back."""
        self.wait_for_connected(self.sim, 15.0)
        gcs = MavlinkListener(14550, 14555, src_system=255, src_component=190)
        try:
            bridge = ('127.0.0.1', 14555)
            self.wait_until(lambda: bridge in gcs.senders.get('ATTITUDE_QUATERNION', ()), 10.0,
                            'the FCU stream from the bridge (%s:%d) at the ground station' % bridge)
            def vehicle_beats():
                return [m for m in gcs.of_type('HEARTBEAT') if m.type == mavlink.MAV_TYPE_QUADROTOR]
            self.wait_until(vehicle_beats, 5.0, 'a HEARTBEAT of the vehicle at the ground station')
            target = vehicle_beats()[0].get_srcSystem()
            asked = time.monotonic()
            gcs.send(gcs.mav.command_long_encode(target, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                                 mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0))
            self.wait_until(lambda: any(a.command == mavlink.MAV_CMD_REQUEST_MESSAGE and a.target_system == 255
                                        for a in gcs.of_type('COMMAND_ACK', asked)), 5.0,
                            'the ground station\'s REQUEST_MESSAGE got no COMMAND_ACK through the bridge')
            self.wait_until(lambda: gcs.of_type('AUTOPILOT_VERSION', asked), 5.0, 'no AUTOPILOT_VERSION came back')
            self.assertIn(bridge, gcs.senders['COMMAND_ACK'], 'the answer came back through the bridge')
        finally:
            gcs.close()

    def test_09c_fcu_stamped_topics_are_on_ros_time(self):
        """After the timesync filter converged (20 samples here), pose, imu, global and altitude are
        stamped FCU time + offset, so on ROS time: no stamp ahead of its arrival by more than 20 ms (the
        issue's bound; the filter takes no sample whose round trip exceeds 10 ms, so a starved bridge
        or test makes arrivals later, never stamps earlier), and the quickest arrival of each topic
        within 250 ms of its stamp (a stamp left on FCU time, or on a stale offset, is off by the
        vehicle's uptime or more). How quickly it comes, the clock's error plus the data's age and
        its delivery (20 ms at most on an idle machine), is a wall-clock figure of the machine's load:
        `./run bench` measures it (FCU-stamped imu/data), this test does not."""
        self.wait_for_connected(self.sim, 15.0)
        got = {}

        def record(topic):
            return lambda msg: got.setdefault(topic, []).append((rospy.Time.now(), msg.header.stamp))
        subs = [rospy.Subscriber('mavros/' + topic, cls, record(topic)) for topic, cls in (
            ('local_position/pose', PoseStamped), ('imu/data', Imu), ('global_position/global', NavSatFix),
            ('altitude', Altitude))]
        try:
            time.sleep(5.0)  # 3 s from connection at least: the filter has its 20 samples
            got.clear()
            self.wait_until(lambda: len(got) == 4 and all(len(v) >= 20 for v in got.values()), 10.0,
                            '20 messages on each FCU-stamped topic')
        finally:
            for sub in subs:
                sub.unregister()
        for topic, pairs in got.items():
            lags = sorted((arrival - stamp).to_sec() * 1000.0 for arrival, stamp in pairs)
            self.assertGreaterEqual(lags[0], -20.0, '%s: header stamps ahead of their arrival (ms): %s' % (
                topic, ['%.1f' % lag for lag in lags if lag < -20.0]))
            self.assertLessEqual(lags[0], 250.0, '%s: even the quickest arrival is %.1f ms after its stamp: the '
                                 'stamps are not on ROS time (all, ms: %s)' % (topic, lags[0],
                                                                               ['%.1f' % lag for lag in lags]))

    def test_09d_more_mavros_topics_carry_the_fcus_data(self):
        """The topics mavros users reach for, at the rate of the FCU message behind each (PX4's
        onboard stream: GLOBAL_POSITION_INT and HIGHRES_IMU 50 Hz, LOCAL_POSITION_NED 30 Hz,
        POSITION_TARGET_LOCAL_NED 10 Hz, GPS_RAW_INT 8 Hz, SYSTEM_TIME 1 Hz, BATTERY_STATUS 0.5 Hz;
        /mavlink/from carries every frame: about 405 a second). imu/mag, imu/static_pressure and
        imu/temperature_imu follow HIGHRES_IMU's fresh-field bits, as mavros's do: PX4 SIH's magnetometer
        and barometer rates (sim.mavlink.sensor_messages, held to the recording by test_sim_telemetry).
        raw/gps_vel is left out: on the ground GPS_RAW_INT has no course, and mavros then
        publishes none (a unit test holds the moving case)."""
        expected = {  # topic: (type, FCU rate in Hz)
            'global_position/local': (Odometry, 50), 'global_position/rel_alt': (Float64, 50),
            'global_position/compass_hdg': (Float64, 50), 'global_position/raw/fix': (NavSatFix, 8),
            'global_position/raw/satellites': (UInt32, 8),
            'local_position/odom': (Odometry, 30), 'local_position/velocity_body': (TwistStamped, 30),
            'imu/data_raw': (Imu, 50), 'imu/mag': (MagneticField, MAG_RATE_HZ),
            'imu/static_pressure': (FluidPressure, BARO_RATE_HZ), 'imu/temperature_imu': (Temperature, BARO_RATE_HZ),
            'setpoint_raw/target_local': (PositionTarget, 10),
            'time_reference': (TimeReference, 1), 'battery': (BatteryState, 0.5), '/tf': (TFMessage, 30),
            'vfr_hud': (VFR_HUD, 10), 'estimator_status': (EstimatorStatus, 1), 'timesync_status': (TimesyncStatus, 10),
            'setpoint_raw/target_attitude': (AttitudeTarget, 10), '/mavlink/from': (Mavlink, 405)}
        self.wait_for_connected(self.sim, 15.0)
        counts = {topic: 0 for topic in expected}

        def count(topic):
            def callback(_msg):
                counts[topic] += 1
            return callback
        subs = [rospy.Subscriber(topic if topic.startswith('/') else 'mavros/' + topic, cls, count(topic))
                for topic, (cls, _rate) in expected.items()]
        window = 8.0
        try:
            time.sleep(1.0)
            for topic in counts:
                counts[topic] = 0
            time.sleep(window)
        finally:
            for sub in subs:
                sub.unregister()
        rates = {topic: counts[topic] / window for topic in counts}
        print('bridge topic rates (Hz): ' + ', '.join('%s %.1f' % kv for kv in sorted(rates.items())))
        for topic, (_cls, rate) in expected.items():
            low = rate * 0.8 if rate >= 1 else 0.2  # BATTERY_STATUS: 4 in 8 s, allow for the window's edges
            self.assertGreaterEqual(rates[topic], low, '%s: %.1f Hz, the FCU sends at %g Hz' % (topic, rates[topic], rate))
            self.assertLessEqual(rates[topic], rate * 1.2 + 0.2, '%s: %.1f Hz' % (topic, rates[topic]))

    def test_09e_diagnostics_as_real_mavros_gives_them(self):
        """/diagnostics against real mavros 1.21's, recorded on the same simulated vehicle in flight
        (reference/mavros-1.21-diagnostics.txt): the statuses in its order, each with its level, its
        message and its keys in their order (the System status's 'Logging' only while the logger runs)."""
        self.wait_for_connected(self.sim, 15.0)
        path = os.path.join(rospkg.RosPack().get_path('offboard_py'), 'reference', 'mavros-1.21-diagnostics.txt')
        real = read_diagnostics_echo(open(path).read())
        time.sleep(3.0)  # a BATTERY_STATUS (0.5 Hz) and the events of some periods
        # the silent bridge publishes on /diagnostics too, as two mavros would: ours is the simulator's
        fcu_url = rospy.get_param('mavros/fcu_url')
        deadline = time.monotonic() + 10.0
        while True:
            ours = rospy.wait_for_message('/diagnostics', DiagnosticArray, 5.0)
            if ours.status and ours.status[0].hardware_id == fcu_url:
                break
            self.assertLess(time.monotonic(), deadline, 'no /diagnostics from the bridge of %s in 10 s' % fcu_url)
        got = [(s.name, s.level, s.message, [kv.key for kv in s.values]) for s in ours.status]
        self.assertEqual([g[0] for g in got], [r[0] for r in real], 'the statuses and their order')

        def steady(status):  # the logger's line comes and goes with it (PX4 stops it after a disarm)
            return status[:3] + ([key for key in status[3] if key != 'Logging'],)
        for mine, theirs in zip(map(steady, got), map(steady, real)):
            self.assertEqual(mine, theirs, 'status %s: ours (name, level, message, keys), then real mavros\'s'
                             % mine[0])

    def test_09f_every_topic_real_mavros_publishes(self):
        """Every topic real mavros 1.21 published in flight on the same simulated vehicle
        (reference/mavros-1.21-topics-in-flight.tsv) carries messages of its type from the bridge too;
        raw/gps_vel only with a course over the ground, which this vehicle on the ground has not."""
        self.wait_for_connected(self.sim, 15.0)
        path = os.path.join(rospkg.RosPack().get_path('offboard_py'), 'reference', 'mavros-1.21-topics-in-flight.tsv')
        rows = [line.rstrip('\n').split('\t') for line in open(path) if not line.startswith('#')][1:]
        expected = {topic: msg_type for topic, msg_type, _ in rows if topic != '/mavros/global_position/raw/gps_vel'}
        seen = {}

        def record(topic):
            return lambda msg: seen.setdefault(topic, msg._connection_header['type'])
        subs = [rospy.Subscriber(topic, rospy.AnyMsg, record(topic)) for topic in expected]
        deadline = time.monotonic() + 20.0
        try:
            while len(seen) < len(expected) and time.monotonic() < deadline:
                time.sleep(0.1)
        finally:
            for sub in subs:
                sub.unregister()
        self.assertEqual(sorted(set(expected) - set(seen)), [], 'no message in 20 s on these topics real mavros '
                         'publishes')
        self.assertEqual(seen, expected, 'each topic\'s type as real mavros\'s')

    def test_10_disconnected_after_timeout(self):
        self.wait_for_connected(self.silent, 10.0)
        self.fcu.beating = False
        stopped = time.monotonic()
        self.wait_until(lambda: not self.silent.state.connected, 3.0 + 1.0 + 0.5, 'disconnected State',
                        [self.silent])
        self.assertLessEqual(time.monotonic() - stopped, 3.0 + 1.0 + 0.5)
        self.assertGreaterEqual(time.monotonic() - stopped, 2.4, 'not before conn/timeout')
        s = self.silent.state
        self.assertEqual((s.armed, s.guided, s.mode, s.system_status), (False, False, '', mavlink.MAV_STATE_UNINIT))
        self.fcu.beating = True
        self.wait_for_connected(self.silent, 3.0)


    def test_11_attitude_then_global_setpoints_fly_through_mavros_topics(self):
        """A user's code on mavros's setpoint_raw topics flies the simulated PX4 as PX4 flies it: level
        attitude at thrust 0.6 (setpoint_raw/attitude) is the offboard signal and climbs; then a global
        position (setpoint_raw/global, GLOBAL_REL_ALT 2.5 m over where it is) takes it to PX4's local z
        for it, 2.5 m less home's local height (PX4's receiver adds home's offset with the sign turned)."""
        self.wait_for_connected(self.sim, 15.0)
        home = rospy.wait_for_message('mavros/home_position/home', HomePosition, 20.0)
        fix = rospy.wait_for_message('mavros/global_position/global', NavSatFix, 5.0)
        attitude = rospy.Publisher('mavros/setpoint_raw/attitude', AttitudeTarget, queue_size=10)
        global_sp = rospy.Publisher('mavros/setpoint_raw/global', GlobalPositionTarget, queue_size=10)
        level = AttitudeTarget(type_mask=AttitudeTarget.IGNORE_ROLL_RATE | AttitudeTarget.IGNORE_PITCH_RATE
                               | AttitudeTarget.IGNORE_YAW_RATE, thrust=0.6)
        level.orientation.w = 1.0
        target = GlobalPositionTarget(coordinate_frame=GlobalPositionTarget.FRAME_GLOBAL_REL_ALT,
                                      type_mask=GlobalPositionTarget.IGNORE_VX | GlobalPositionTarget.IGNORE_VY
                                      | GlobalPositionTarget.IGNORE_VZ | GlobalPositionTarget.IGNORE_AFX
                                      | GlobalPositionTarget.IGNORE_AFY | GlobalPositionTarget.IGNORE_AFZ
                                      | GlobalPositionTarget.IGNORE_YAW_RATE,
                                      latitude=fix.latitude, longitude=fix.longitude, altitude=2.5, yaw=0.0)
        stream = {'msg': level, 'pub': attitude}
        stop = threading.Event()

        def run():
            while not stop.is_set():
                msg = stream['msg']
                msg.header.stamp = rospy.Time.now()
                stream['pub'].publish(msg)
                stop.wait(0.05)
        thread = threading.Thread(target=run, daemon=True)
        thread.start()
        try:
            time.sleep(1.0)
            self.assertTrue(self.set_mode(self.sim, 'OFFBOARD'))
            self.wait_for_mode(self.sim, 'OFFBOARD', 4.0)
            self.assertTrue(self.set_arm(self.sim, True).success, 'attitude setpoints are the offboard signal')
            self.wait_until(lambda: self.sim.z() > 3.0, 15.0, 'a climb past 3 m at thrust 0.6', [self.sim])
            stream.update(msg=target, pub=global_sp)
            want = 2.5 - home.position.z
            self.wait_until(lambda: abs(self.sim.z() - want) < 0.35, 20.0,
                            'local z within 0.35 m of %.2f m' % want, [self.sim])
            self.assertEqual(self.sim.state.mode, 'OFFBOARD')
        finally:
            stop.set()
            thread.join()


if __name__ == '__main__':
    rospy.init_node('test_bridge')
    rostest.rosrun(PKG, 'bridge', BridgeTest)
