"""The bridge's plugins offline: a fake FCU link, in-memory ROS endpoints, no roscore.

Each test builds the real Bridge with the plugin under test on the fakes of bridge_rig (a
FakeLink, a FakeFcu answering from a per-message-type script, FakeRos, FakeClock moved by the test).
"""

import math
import struct
import threading
import time

import pytest
import rospy
from geometry_msgs.msg import PoseStamped
from mavros_msgs.msg import Waypoint
from mavros_msgs.srv import (CommandBoolRequest, CommandTOLRequest, ParamGetRequest, ParamPullRequest,
                             ParamSetRequest, SetModeRequest, WaypointClearRequest, WaypointPullRequest,
                             WaypointPushRequest)

from offboard_py import frames
from offboard_py.bridge import (command, core, global_position, home_position, imu, local_position, mission, node,
                                param, setpoint, sys_status)
from offboard_py.bridge.config import ConfigError, read_config
from offboard_py.bridge.core import Bridge
from offboard_py.dialect import HIGHRES_IMU_UPDATED_ACCEL_GYRO, mavlink
from offboard_py.testing.reference import mavros_figure

from bridge_rig import AUTO_LOITER, BUILD, OFFBOARD, FakeClock, FakeRos, Rig, heartbeat, same_rotation, wait_until


def test_all_plugins_offer_mavros_names_latching_and_queues():
    rig = Rig(*node.PLUGINS)
    assert set(rig.ros.services) == {
        '~set_mode', '~cmd/arming', '~cmd/takeoff', '~cmd/land', '~cmd/command', '~cmd/command_int',
        '~set_message_interval', '~set_stream_rate', '~param/pull', '~param/get', '~param/set', '~param/push',
        '~mission/push', '~mission/pull', '~mission/clear', '~mission/set_current', '~cmd/command_ack',
        '~geofence/push', '~geofence/pull', '~geofence/clear', '~rallypoint/push', '~rallypoint/pull',
        '~rallypoint/clear',
        '~cmd/set_home', '~home_position/req_update'}
    assert set(rig.ros.subscriptions) == {'~setpoint_position/local', '~setpoint_raw/local',
                                          '~setpoint_velocity/cmd_vel', '~setpoint_velocity/cmd_vel_unstamped',
                                          '~setpoint_raw/attitude', '~setpoint_raw/global', '~setpoint_position/global',
                                          '~setpoint_attitude/cmd_vel', '~setpoint_attitude/thrust',
                                          '~statustext/send', 'mavlink/to'}
    topics = rig.ros.topics
    assert set(topics) == {
        '~state', '~extended_state', '~local_position/pose', '~local_position/velocity_local',
        '~local_position/velocity_body', '~local_position/odom', '~global_position/global',
        '~global_position/local', '~global_position/rel_alt', '~global_position/compass_hdg',
        '~global_position/raw/fix', '~global_position/raw/gps_vel', '~global_position/raw/satellites',
        '~altitude', '~imu/data', '~imu/data_raw', '~imu/mag', '~imu/static_pressure', '~imu/temperature_imu',
        '~imu/diff_pressure', '~imu/temperature_baro',
        '~home_position/home', '~mission/waypoints', '~mission/reached', '~time_reference', '~battery',
        '~geofence/waypoints', '~rallypoint/waypoints',
        '~setpoint_raw/target_local', '~setpoint_raw/target_attitude', '~setpoint_raw/target_global', '~statustext/recv', '~vfr_hud', '~rc/in',
        '~rc/out', '~sys_status', '~estimator_status', '~timesync_status', 'mavlink/from', '/diagnostics', '/tf',
        '/tf_static'}
    assert {name for name, pub in topics.items() if pub.latch} == {
        '~state', '~home_position/home', '~mission/waypoints', '~mission/reached', '~geofence/waypoints',
        '~rallypoint/waypoints', '/tf_static'}
    assert {name: pub.queue_size for name, pub in topics.items() if pub.queue_size != 10} == {
        '~home_position/home': 2, '~mission/waypoints': 2, '~geofence/waypoints': 2, '~rallypoint/waypoints': 2,
        'mavlink/from': 100, '/tf': 100, '/tf_static': 1}


def test_tf_static_carries_mavros_ned_and_frd_frames():
    """mavros latches map -> map_ned, odom -> odom_ned (ENU to NED: 180 deg about (1, 1, 0)/sqrt 2) and
    base_link -> base_link_frd (FLU to FRD: 180 deg about x) at start, and advertises /tf, with or
    without local_position/tf/send (reference/mavros-1.21-px4-api.txt: one publisher each)."""
    rig = Rig(*node.PLUGINS)
    [static] = rig.published('/tf_static')
    got = {(t.header.frame_id, t.child_frame_id): (t.transform.rotation.x, t.transform.rotation.y,
                                                    t.transform.rotation.z, t.transform.rotation.w)
           for t in static.transforms}
    half = math.sqrt(0.5)
    assert set(got) == {('map', 'map_ned'), ('odom', 'odom_ned'), ('base_link', 'base_link_frd')}
    assert same_rotation(got['map', 'map_ned'], (half, half, 0, 0)) and same_rotation(got['odom', 'odom_ned'],
                                                                                    (half, half, 0, 0))
    assert same_rotation(got['base_link', 'base_link_frd'], (1, 0, 0, 0))
    assert all(t.header.stamp == rospy.Time(1000) and t.transform.translation.x == 0 for t in static.transforms)


# -- sys_status --------------------------------------------------------------------------------

def test_heartbeat_connects_publishes_state_and_asks_for_capabilities_1_s_later():
    """As real mavros: COMMAND_LONG 520 1.0 s after PX4's first HEARTBEAT (reference/px4-sitl-measured.md,
    "Recorded conversations"), once per connection."""
    rig = Rig(sys_status.SysStatus)
    states = rig.published('~state')
    assert rig.ros.topics['~state'].latch and len(states) == 1 and not states[0].connected
    rig.tick(100.0)
    rig.fcu.send(heartbeat(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
                           | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED))
    state = states[-1]
    assert (state.connected, state.armed, state.guided, state.mode) == (True, True, True, 'AUTO.LOITER')
    assert state.system_status == mavlink.MAV_STATE_STANDBY
    rig.tick(100.9)
    assert rig.fcu.got('COMMAND_LONG') == [], 'not before 1 s'
    rig.tick(101.0)
    assert wait_until(lambda: rig.fcu.got('COMMAND_LONG'))
    [request] = rig.fcu.got('COMMAND_LONG')
    assert request.command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES and request.param1 == 1
    rig.fcu.send(heartbeat())
    rig.tick(105.0)
    time.sleep(0.05)
    assert len(rig.fcu.got('COMMAND_LONG')) == 1, 'capabilities are asked for once per connection'


def test_our_heartbeat_is_mavros_s_manual_armed_onboard_controller():
    """Real mavros's HEARTBEAT: ONBOARD_CONTROLLER, autopilot INVALID, base_mode 192 (MAV_MODE_MANUAL_ARMED),
    custom_mode 0, ACTIVE (reference/conversations/takeoff-mavros-px4)."""
    rig = Rig(sys_status.SysStatus)
    rig.tick(100.0)
    [hb] = rig.fcu.got('HEARTBEAT')
    assert (hb.type, hb.autopilot, hb.base_mode, hb.custom_mode, hb.system_status) == (
        mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 192, 0, mavlink.MAV_STATE_ACTIVE)


@pytest.mark.parametrize('name, mav_type', [('GCS', mavlink.MAV_TYPE_GCS),
                                             ('ONBOARD_CONTROLLER', mavlink.MAV_TYPE_ONBOARD_CONTROLLER),
                                             ('gcs', mavlink.MAV_TYPE_GENERIC), ('NO_SUCH_TYPE', mavlink.MAV_TYPE_GENERIC)])
def test_heartbeat_mav_type_names_the_type_as_mavros(name, mav_type):
    """mavros's conn/heartbeat_mav_type (mav_type_from_str: the exact MAV_TYPE name, GENERIC otherwise).
    GCS is how a ROS user hears PX4's texts: PX4 sends STATUSTEXT only where a GCS heartbeat is heard."""
    rig = Rig(sys_status.SysStatus, conn__heartbeat_mav_type=name)
    rig.tick(100.0)
    assert rig.fcu.got('HEARTBEAT')[0].type == mav_type


def test_heartbeat_from_another_component_or_system_is_ignored():
    rig = Rig(sys_status.SysStatus)
    camera = mavlink.MAVLink(None, srcSystem=1, srcComponent=mavlink.MAV_COMP_ID_CAMERA)
    other_vehicle = mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
    rig.fcu.send(heartbeat(), codec=camera)
    rig.fcu.send(heartbeat(), codec=other_vehicle)
    assert not rig.bridge.connected
    assert [s.connected for s in rig.published('~state')] == [False]
    assert rig.fcu.got('COMMAND_LONG') == []


def test_other_components_of_the_target_system_pass_the_default_filter():
    rig = Rig(sys_status.SysStatus)
    camera = mavlink.MAVLink(None, srcSystem=1, srcComponent=mavlink.MAV_COMP_ID_CAMERA)
    other_vehicle = mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
    rig.fcu.send(BUILD.extended_sys_state_encode(0, mavlink.MAV_LANDED_STATE_IN_AIR), codec=camera)
    rig.fcu.send(BUILD.extended_sys_state_encode(0, mavlink.MAV_LANDED_STATE_ON_GROUND), codec=other_vehicle)
    assert [m.landed_state for m in rig.published('~extended_state')] == [mavlink.MAV_LANDED_STATE_IN_AIR]


def test_connection_times_out_after_conn_timeout():
    rig = Rig(sys_status.SysStatus, conn__timeout=2.0)
    rig.fcu.send(heartbeat())
    assert rig.bridge.connected
    rig.tick(101.9)
    assert rig.bridge.connected, 'still within conn/timeout'
    rig.tick(102.2)
    assert not rig.bridge.connected
    assert [s.connected for s in rig.published('~state')] == [False, True, False]
    rig.tick(105.0)
    assert len(rig.published('~state')) == 3, 'one disconnected State, not one per check'


def test_our_heartbeat_is_an_onboard_controller_at_heartbeat_rate():
    rig = Rig(sys_status.SysStatus, conn__heartbeat_rate=2.0)
    for t in (100.0, 100.2, 100.5, 100.7, 101.0):
        rig.tick(t)
    beats = rig.fcu.got('HEARTBEAT')
    assert len(beats) == 3
    assert (beats[0].type, beats[0].autopilot, beats[0].system_status) == (
        mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, mavlink.MAV_STATE_ACTIVE)


def test_set_mode_sends_custom_mode_and_keeps_armed():
    rig = Rig(sys_status.SysStatus)
    rig.fcu.send(heartbeat(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED))
    assert rig.call('~set_mode', SetModeRequest(custom_mode='offboard')).mode_sent
    rig.fcu.send(heartbeat(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED))
    assert rig.call('~set_mode', SetModeRequest(custom_mode='0x%x' % AUTO_LOITER)).mode_sent
    sent = [(m.target_system, m.base_mode, m.custom_mode) for m in rig.fcu.got('SET_MODE')]
    assert sent == [(1, 1, OFFBOARD), (1, 1 | 128, AUTO_LOITER)]


def test_set_mode_refuses_an_unknown_mode():
    rig = Rig(sys_status.SysStatus)
    rig.fcu.send(heartbeat())
    assert not rig.call('~set_mode', SetModeRequest(custom_mode='HOVER')).mode_sent
    assert rig.fcu.got('SET_MODE') == []


def test_set_mode_before_any_heartbeat_is_not_sent():
    """mavros picks the mode table by the FCU's autopilot; before a HEARTBEAT it has none
    ("MODE: Unsupported FCU") and answers mode_sent false without sending."""
    rig = Rig(sys_status.SysStatus)
    assert not rig.call('~set_mode', SetModeRequest(custom_mode='OFFBOARD')).mode_sent
    assert rig.fcu.got('SET_MODE') == []


@pytest.mark.parametrize('text, custom_mode', [
    ('6abc', 6), ('-1', 0xFFFFFFFF), (' 7', 7), ('0x10', 16), ('010', 8), ('0xZ', 0), ('+5', 5),
    ('auto.loiter', AUTO_LOITER), ('2147483647', 0x7FFFFFFF)])
def test_set_mode_reads_numbers_as_mavros_s_std_stoi(text, custom_mode):
    rig = Rig(sys_status.SysStatus)
    rig.fcu.send(heartbeat())
    assert rig.call('~set_mode', SetModeRequest(custom_mode=text)).mode_sent
    assert rig.fcu.got('SET_MODE')[-1].custom_mode == custom_mode


@pytest.mark.parametrize('text', [' OFFBOARD', 'OFFBOARD ', 'x6', '-', 'AUTO_LOITER'])
def test_set_mode_refuses_what_is_neither_an_exact_name_nor_a_number(text):
    rig = Rig(sys_status.SysStatus)
    rig.fcu.send(heartbeat())
    assert not rig.call('~set_mode', SetModeRequest(custom_mode=text)).mode_sent
    assert rig.fcu.got('SET_MODE') == []


def test_set_mode_with_a_number_outside_int_fails_the_call_as_mavros_s_stoi_throws():
    rig = Rig(sys_status.SysStatus)
    rig.fcu.send(heartbeat())
    with pytest.raises(rospy.ServiceException, match='outside a 32-bit int'):
        rig.call('~set_mode', SetModeRequest(custom_mode='4294967296'))
    assert rig.fcu.got('SET_MODE') == []
    assert rig.call('~set_mode', SetModeRequest(custom_mode='OFFBOARD')).mode_sent, 'the service still answers'


# -- command -----------------------------------------------------------------------------------

def ack_with(result, command_id=None):
    """An FCU script: answer each COMMAND_LONG with COMMAND_ACK(result), for command_id if given."""
    return lambda m: [BUILD.command_ack_encode(command_id or m.command, result)]


def test_command_without_ack_fails_after_the_timeout():
    rig = Rig(command.Command, cmd__command_ack_timeout=0.1)
    started = time.monotonic()
    response = rig.call('~cmd/arming', CommandBoolRequest(value=True))
    assert (response.success, response.result) == (False, mavlink.MAV_RESULT_FAILED)
    assert 0.1 <= time.monotonic() - started < 1.0
    [sent] = rig.fcu.got('COMMAND_LONG')
    assert (sent.target_system, sent.target_component, sent.command, sent.param1) == (
        1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)


def test_command_ack_gives_its_result():
    rig = Rig(command.Command)
    rig.fcu.answers['COMMAND_LONG'] = ack_with(mavlink.MAV_RESULT_ACCEPTED)
    response = rig.call('~cmd/arming', CommandBoolRequest(value=False))
    assert (response.success, response.result) == (True, mavlink.MAV_RESULT_ACCEPTED)
    assert rig.fcu.got('COMMAND_LONG')[0].param1 == 0.0
    rig.fcu.answers['COMMAND_LONG'] = ack_with(mavlink.MAV_RESULT_DENIED)
    response = rig.call('~cmd/land', CommandTOLRequest())
    assert (response.success, response.result) == (False, mavlink.MAV_RESULT_DENIED)


def test_ack_for_another_command_does_not_answer():
    rig = Rig(command.Command, cmd__command_ack_timeout=0.1)
    rig.fcu.answers['COMMAND_LONG'] = ack_with(mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_CMD_NAV_LAND)
    response = rig.call('~cmd/arming', CommandBoolRequest(value=True))
    assert (response.success, response.result) == (False, mavlink.MAV_RESULT_FAILED)


def test_an_ack_nobody_waits_for_is_logged_as_mavros_does_at_most_every_10_s(monkeypatch):
    """mavros's cmd plugin: ROS_WARN_THROTTLE(10, "CMD: Unexpected command %u, result %u"), as it
    logs for PX4's ACK of the AUTOPILOT_VERSION request (520) sent on connection."""
    warnings = []
    monkeypatch.setattr(command.rospy, 'logwarn', lambda fmt, *args: warnings.append(fmt % args))
    now = [100.0]
    waiter = command.CommandWaiter(clock=lambda: now[0])
    ack = mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 0)
    waiter.on_ack(ack)
    now[0] += 9.0
    waiter.on_ack(ack)
    assert warnings == ['CMD: Unexpected command 520, result 0'] and waiter.unexpected == 2
    now[0] += 1.0
    waiter.on_ack(mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_NAV_LAND, 4))
    assert warnings[1:] == ['CMD: Unexpected command 21, result 4']
    # a command a plugin sent expecting its ACK (home_position's request, as mavros's waits for it)
    now[0] += 20.0
    waiter.expect(mavlink.MAV_CMD_GET_HOME_POSITION)
    waiter.on_ack(mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_GET_HOME_POSITION, 0))
    assert len(warnings) == 2 and waiter.unexpected == 3
    waiter.on_ack(mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_GET_HOME_POSITION, 0))
    assert warnings[2:] == ['CMD: Unexpected command 410, result 0'], 'one ACK expected, not every one'
    # an ACK that answers a waiting command is not unexpected
    entry = waiter.begin(mavlink.MAV_CMD_NAV_LAND)
    waiter.on_ack(mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_NAV_LAND, 0))
    assert entry[0].is_set() and entry[1] == 0 and waiter.unexpected == 4


def test_home_position_request_expects_its_ack():
    """home_position asks for HOME_POSITION with a command of its own; its ACK is no surprise to
    the cmd plugin (mavros's home_position asks through cmd/command and waits for it)."""
    rig = Rig(command.Command, home_position.HomePosition)
    rig.fcu.answers['COMMAND_LONG'] = ack_with(mavlink.MAV_RESULT_ACCEPTED)
    rig.tick(103.0)
    rig.bridge.set_connected(True)  # mavros's poll timer starts with the connection
    rig.tick(112.9)
    assert rig.fcu.got('COMMAND_LONG') == [], 'not before 10 s after the connection'
    rig.tick(113.0)
    assert [m.command for m in rig.fcu.got('COMMAND_LONG')] == [mavlink.MAV_CMD_GET_HOME_POSITION]
    assert rig.plugin.waiter.unexpected == 0


def test_home_position_req_update_asks_through_cmd_command_as_mavros():
    """~home_position/req_update: MAV_CMD_GET_HOME_POSITION (confirmation 0), success = the ACK's ACCEPTED."""
    from std_srvs.srv import TriggerRequest
    rig = Rig(home_position.HomePosition, command.Command)
    rig.fcu.answers['COMMAND_LONG'] = ack_with(mavlink.MAV_RESULT_ACCEPTED)
    assert rig.call('~home_position/req_update', TriggerRequest()).success
    [sent] = rig.fcu.got('COMMAND_LONG')
    assert (sent.command, sent.confirmation, sent.target_system) == (mavlink.MAV_CMD_GET_HOME_POSITION, 0, 1)
    rig.fcu.answers['COMMAND_LONG'] = ack_with(mavlink.MAV_RESULT_DENIED)
    assert not rig.call('~home_position/req_update', TriggerRequest()).success
    assert rig.plugin.bridge.commands.unexpected == 0


def test_home_position_req_update_without_the_cmd_plugin_fails_as_mavros_s_call_does():
    from std_srvs.srv import TriggerRequest
    rig = Rig(home_position.HomePosition)
    assert not rig.call('~home_position/req_update', TriggerRequest()).success
    assert rig.fcu.got('COMMAND_LONG') == []


def test_no_home_request_once_home_position_came():
    rig = Rig(home_position.HomePosition)
    rig.tick(103.0)
    rig.bridge.set_connected(True)
    rig.fcu.send(BUILD.home_position_encode(473977420, 85455940, 488000, 0, 0, 0, [1, 0, 0, 0], 0, 0, 0))
    rig.tick(125.0)
    assert rig.fcu.got('COMMAND_LONG') == [], 'PX4 streams HOME_POSITION: mavros never asks'


def test_home_position_is_published_as_mavros_1_21_publishes_it():
    """PX4 SITL's recorded HOME_POSITION (the replay's) and what real mavros 1.21 published for it on the
    same replay (bench/results/2026-11-25-mavros-side-by-side.md): the orientation turned from the NED
    to the ENU world with the body's axes left alone (mavros's transform_orientation_ned_enu), no frame_id."""
    q_wxyz = [0.9997270703315735, -0.0028137785848230124, 0.0032545786816626787, 0.022963205352425575]
    mavros_xyzw = (0.7231512289896955, 0.6906763525447367, 0.004290976573794738, -0.00031169273762297195)
    rig = Rig(home_position.HomePosition)
    rig.fcu.send(BUILD.home_position_encode(473977433, 85455940, 488000, 0.0546, -0.128, -1.368, q_wxyz, 0, 0, 0))
    [home] = rig.published('~home_position/home')
    q = home.orientation
    assert (q.x, q.y, q.z, q.w) == pytest.approx(mavros_xyzw, abs=1e-9)
    assert home.header.frame_id == ''
    assert (home.position.x, home.position.y, home.position.z) == pytest.approx((-0.128, 0.0546, 1.368))


def test_takeoff_carries_position_and_yaw():
    rig = Rig(command.Command)
    rig.fcu.answers['COMMAND_LONG'] = ack_with(mavlink.MAV_RESULT_ACCEPTED)
    assert rig.call('~cmd/takeoff', CommandTOLRequest(min_pitch=0.1, yaw=1.5, latitude=47.25, longitude=8.5,
                                                      altitude=500.0)).success
    [sent] = rig.fcu.got('COMMAND_LONG')
    assert sent.command == mavlink.MAV_CMD_NAV_TAKEOFF
    assert [sent.param1, sent.param4, sent.param5, sent.param6, sent.param7] == pytest.approx(
        [0.1, 1.5, 47.25, 8.5, 500.0])


def test_second_call_for_a_waiting_command_is_refused():
    rig = Rig(command.Command, cmd__command_ack_timeout=5.0)
    results = []
    first = threading.Thread(target=lambda: results.append(rig.call('~cmd/arming', CommandBoolRequest(value=True))))
    first.start()
    assert wait_until(lambda: rig.fcu.got('COMMAND_LONG')), 'the first call sent no COMMAND_LONG'
    with pytest.raises(rospy.ServiceException):
        rig.call('~cmd/arming', CommandBoolRequest(value=True))
    rig.fcu.send(BUILD.command_ack_encode(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_RESULT_ACCEPTED))
    first.join(2.0)
    assert not first.is_alive() and results[0].success
    assert len(rig.fcu.got('COMMAND_LONG')) == 1, 'the refused call sends nothing'


def test_a_broadcast_of_a_command_that_waits_for_its_ack_is_refused_as_mavros():
    """mavros's send_command_long_and_wait looks for the command among those waiting before it looks
    at broadcast: the call fails and nothing is sent."""
    from mavros_msgs.srv import CommandLongRequest
    rig = Rig(command.Command, cmd__command_ack_timeout=5.0)
    first = threading.Thread(target=lambda: rig.call('~cmd/arming', CommandBoolRequest(value=True)))
    first.start()
    assert wait_until(lambda: rig.fcu.got('COMMAND_LONG')), 'the first call sent no COMMAND_LONG'
    with pytest.raises(rospy.ServiceException):
        rig.call('~cmd/command', CommandLongRequest(broadcast=True, command=mavlink.MAV_CMD_COMPONENT_ARM_DISARM))
    rig.fcu.send(BUILD.command_ack_encode(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_RESULT_ACCEPTED))
    first.join(2.0)
    assert len(rig.fcu.got('COMMAND_LONG')) == 1, 'the refused broadcast sends nothing'


# -- mission -----------------------------------------------------------------------------------

def waypoint(frame, cmd, x, y, z, current=False):
    return Waypoint(frame=frame, command=cmd, is_current=current, autocontinue=True, x_lat=x, y_long=y, z_alt=z)


PLAN = [waypoint(mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_TAKEOFF, 47.397742, 8.545594, 10.0, True),
        waypoint(mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_CMD_NAV_WAYPOINT, 1.5, -2.25, -5.0)]


class MissionFcu:
    """The FCU's side of the mission protocol: takes an upload, serves its items on a download."""

    def __init__(self, fcu, legacy=False, result=mavlink.MAV_MISSION_ACCEPTED):
        self.legacy, self.result = legacy, result
        self.count, self.items = 0, []
        self.mission_type = mavlink.MAV_MISSION_TYPE_MISSION  # of the upload under way
        fcu.answers.update({'MISSION_COUNT': self._on_count, 'MISSION_ITEM_INT': self._on_item,
                            'MISSION_ITEM': self._on_item, 'MISSION_REQUEST_LIST': self._on_request_list,
                            'MISSION_REQUEST_INT': self._on_request, 'MISSION_CLEAR_ALL': self._on_clear})

    def _on_clear(self, msg):
        return [BUILD.mission_ack_encode(1, mavlink.MAV_COMP_ID_UDP_BRIDGE, self.result, msg.mission_type)]

    def _request(self, seq):
        encode = BUILD.mission_request_encode if self.legacy else BUILD.mission_request_int_encode
        return encode(1, mavlink.MAV_COMP_ID_UDP_BRIDGE, seq, self.mission_type)

    def _on_count(self, msg):
        self.count, self.items, self.mission_type = msg.count, [], msg.mission_type
        return [self._request(0)]

    def _on_item(self, msg):
        self.items.append(msg)
        if len(self.items) < self.count:
            return [self._request(len(self.items))]
        return [BUILD.mission_ack_encode(1, mavlink.MAV_COMP_ID_UDP_BRIDGE, self.result, self.mission_type)]

    def _on_request_list(self, msg):
        """The mission's count; an empty geofence and rally list, as PX4 SITL answers on a fresh start."""
        mission_type = msg.mission_type
        count = len(self.items) if mission_type == mavlink.MAV_MISSION_TYPE_MISSION else 0
        return [BUILD.mission_count_encode(1, mavlink.MAV_COMP_ID_UDP_BRIDGE, count, mission_type)]

    def _on_request(self, msg):
        item = self.items[msg.seq]
        return [BUILD.mission_item_int_encode(1, mavlink.MAV_COMP_ID_UDP_BRIDGE, msg.seq, item.frame, item.command,
                                                 item.current, item.autocontinue, 0, 0, 0, 0, item.x, item.y, item.z)]


def test_mission_push_sends_items_as_mission_item_int():
    rig = Rig(mission.Mission)
    fcu = MissionFcu(rig.fcu)
    response = rig.call('~mission/push', WaypointPushRequest(waypoints=PLAN))
    assert (response.success, response.wp_transfered) == (True, 2)
    assert len(rig.fcu.got('MISSION_COUNT')) == 1 and rig.fcu.got('MISSION_COUNT')[0].count == 2
    takeoff, local = fcu.items
    assert (takeoff.get_type(), takeoff.seq, takeoff.frame, takeoff.current) == (
        'MISSION_ITEM_INT', 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, 1)
    assert (takeoff.x, takeoff.y, takeoff.z) == (473977420, 85455940, 10.0), 'degrees * 1e7'
    assert (local.x, local.y, local.z) == (15000, -22500, -5.0), 'local metres * 1e4'
    assert all(item.mission_type == mavlink.MAV_MISSION_TYPE_MISSION for item in fcu.items)
    published = rig.published('~mission/waypoints')[-1]
    assert [wp.command for wp in published.waypoints] == [mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_WAYPOINT]


def test_geofence_push_uploads_a_fence_as_mavros_s_geofence_plugin():
    """~geofence/push: the same transfer with mission_type FENCE (mavros's geofence plugin is MissionBase with
    MAV_MISSION_TYPE_FENCE), published on ~geofence/waypoints; the mission is left alone."""
    rig = Rig(mission.Mission)
    fcu = MissionFcu(rig.fcu)
    circle = Waypoint(frame=mavlink.MAV_FRAME_GLOBAL, command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
                      param1=5.0, x_lat=47.397742, y_long=8.545594)
    response = rig.call('~geofence/push', WaypointPushRequest(waypoints=[circle]))
    assert (response.success, response.wp_transfered) == (True, 1)
    assert rig.fcu.got('MISSION_COUNT')[0].mission_type == mavlink.MAV_MISSION_TYPE_FENCE
    (item,) = fcu.items
    assert (item.mission_type, item.command, item.param1, item.x, item.y) == (
        mavlink.MAV_MISSION_TYPE_FENCE, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 5.0, 473977420, 85455940)
    assert [wp.command for wp in rig.published('~geofence/waypoints')[-1].waypoints] == [
        mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION]
    assert rig.published('~mission/waypoints')[-1].waypoints == []
    assert rig.call('~geofence/clear', WaypointClearRequest()).success
    assert rig.fcu.got('MISSION_CLEAR_ALL')[-1].mission_type == mavlink.MAV_MISSION_TYPE_FENCE
    assert rig.published('~geofence/waypoints')[-1].waypoints == []


def test_mission_push_converts_x_and_y_as_mavros_s_int32_cast(caplog):
    """mavros sends int32_t(x_lat * factor): truncated toward zero; a NaN or out-of-range value is x86's
    INT32_MIN (0x80000000), with the push answered and a warning naming the field; the factor is 1e7 for
    global frames, 1e4 for local ones and 1 for the rest (MAV_FRAME_MISSION)."""
    rig = Rig(mission.Mission)
    fcu = MissionFcu(rig.fcu)
    plan = [waypoint(mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_WAYPOINT, 47.39774196, -8.54559386, 10.0),
            waypoint(mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_WAYPOINT, float('nan'), 1000.0, 10.0),
            waypoint(mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_NAV_WAYPOINT, 3.7, -2.5, 0.0)]
    response = rig.call('~mission/push', WaypointPushRequest(waypoints=plan))
    assert (response.success, response.wp_transfered) == (True, 3)
    assert [(item.x, item.y) for item in fcu.items] == [(473977419, -85455938), (-2 ** 31, -2 ** 31), (3, -2)]
    warnings = [r.getMessage() for r in caplog.records if r.levelname == 'WARNING']
    assert any('item 1' in w and 'x_lat' in w for w in warnings) and any('item 1' in w and 'y_long' in w
                                                                         for w in warnings), warnings


def test_mission_push_answers_a_legacy_request_with_mission_item():
    rig = Rig(mission.Mission)
    fcu = MissionFcu(rig.fcu, legacy=True)
    assert rig.call('~mission/push', WaypointPushRequest(waypoints=PLAN)).success
    assert [item.get_type() for item in fcu.items] == ['MISSION_ITEM', 'MISSION_ITEM']
    assert (fcu.items[0].x, fcu.items[0].y) == pytest.approx((47.397742, 8.545594))


def test_mission_refused_by_the_fcu_is_a_failed_push():
    rig = Rig(mission.Mission)
    MissionFcu(rig.fcu, result=mavlink.MAV_MISSION_NO_SPACE)
    response = rig.call('~mission/push', WaypointPushRequest(waypoints=PLAN))
    assert (response.success, response.wp_transfered) == (False, 0)
    assert rig.published('~mission/waypoints')[-1].waypoints == []


def test_mission_pull_reads_every_item_and_acknowledges():
    rig = Rig(mission.Mission)
    fcu = MissionFcu(rig.fcu)
    assert rig.call('~mission/push', WaypointPushRequest(waypoints=PLAN)).success
    rig.plugin.waypoints = []
    response = rig.call('~mission/pull', WaypointPullRequest())
    assert (response.success, response.wp_received) == (True, 2)
    assert [m.seq for m in rig.fcu.got('MISSION_REQUEST_INT')] == [0, 1]
    [ack] = rig.fcu.got('MISSION_ACK')
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED
    pulled = rig.published('~mission/waypoints')[-1]
    assert [c for wp in pulled.waypoints for c in (wp.x_lat, wp.y_long)] == pytest.approx([47.397742, 8.545594, 1.5,
                                                                                            -2.25])
    assert pulled.waypoints[0].is_current and len(fcu.items) == 2


def test_mission_pull_from_a_silent_fcu_fails_after_the_retries(monkeypatch):
    monkeypatch.setattr(mission, 'STEP_TIMEOUT_S', 0.02)
    rig = Rig(mission.Mission)
    response = rig.call('~mission/pull', WaypointPullRequest())
    assert (response.success, response.wp_received) == (False, 0)
    assert len(rig.fcu.got('MISSION_REQUEST_LIST')) == mavros_figure('mission', 'requests_per_step')


def test_mission_pull_after_connection_retries_until_the_fcu_answers(monkeypatch):
    """A flood can starve the first pulls: the bridge keeps trying, with back-off,
    while the link is up, warning each time, and the list is there once the FCU answers."""
    monkeypatch.setattr(mission, 'STEP_TIMEOUT_S', 0.02)
    warnings = []
    monkeypatch.setattr(rospy, 'logwarn', lambda text, *args: warnings.append(text % args))
    rig = Rig(mission.Mission)
    fcu = MissionFcu(rig.fcu)
    assert rig.call('~mission/push', WaypointPushRequest(waypoints=PLAN)).success
    rig.plugin.waypoints = []
    answer = fcu._on_request_list
    fcu_requests = []

    def deaf_twice(msg):  # the first two mission pulls (2 x 4 requests) get nothing; fence and rally are answered
        if msg.mission_type != mavlink.MAV_MISSION_TYPE_MISSION:
            return answer(msg)
        fcu_requests.append(msg)
        return answer(msg) if len(fcu_requests) > 2 * mavros_figure('mission', 'requests_per_step') else []
    rig.fcu.answers['MISSION_REQUEST_LIST'] = deaf_twice
    monkeypatch.setattr(core, 'RETRY_DELAYS_S', (0.01,))
    rig.bridge.set_connected(True)
    rig.plugin._auto_pull()
    assert len(rig.plugin.waypoints) == 2
    retries = [w for w in warnings if 'mission pull after connection failed' in w]
    assert len(retries) == 2 and 'trying again' in retries[0], warnings
    # the empty geofence and rally lists, latched, as mavros's geofence and rallypoint plugins publish them
    for topic in ('~geofence/waypoints', '~rallypoint/waypoints'):
        [listed] = rig.published(topic)
        assert (listed.current_seq, listed.waypoints) == (0, []), topic


def test_a_pull_retry_ends_with_an_error_when_the_link_is_gone(monkeypatch):
    errors, warnings = [], []
    monkeypatch.setattr(rospy, 'logerr', lambda text, *args: errors.append(text % args))
    monkeypatch.setattr(rospy, 'logwarn', lambda text, *args: warnings.append(text % args))
    rig = Rig(mission.Mission)
    rig.bridge.set_connected(True)
    tries = []

    def attempt():
        tries.append(1)
        if len(tries) == 2:
            rig.bridge.set_connected(False)
        return False, 'no answer'
    assert rig.bridge.retry_while_connected('X: pull', attempt, delays=(0.01,)) is False
    assert len(tries) == 2 and len(warnings) == 1
    assert errors == ['X: pull failed: no answer; the FCU link is gone (tried again on the next connection)']


# -- param -------------------------------------------------------------------------------------

def int32_on_wire(value):
    """PX4's bytewise encoding, written out here so the test does not trust the code under test."""
    return struct.unpack('<f', struct.pack('<i', value))[0]


PARAMS = [('MAV_SYS_ID', mavlink.MAV_PARAM_TYPE_INT32, 1), ('MPC_XY_VEL_MAX', mavlink.MAV_PARAM_TYPE_REAL32, 12.0),
          ('COM_RCL_EXCEPT', mavlink.MAV_PARAM_TYPE_INT32, 4), ('NAV_DLL_ACT', mavlink.MAV_PARAM_TYPE_INT32, -1),
          ('MIS_TAKEOFF_ALT', mavlink.MAV_PARAM_TYPE_REAL32, 2.5)]


def param_value(index, count=len(PARAMS)):
    name, kind, value = PARAMS[index]
    wire = int32_on_wire(value) if kind == mavlink.MAV_PARAM_TYPE_INT32 else value
    return BUILD.param_value_encode(name.encode(), wire, kind, count, index)


def test_param_pull_rereads_the_missing_indices(monkeypatch):
    monkeypatch.setattr(param, 'QUIET_S', 0.05)
    monkeypatch.setattr(param, 'LIST_TIMEOUT_S', 2.0)
    rig = Rig(param.Param)
    lost = {2, 4}
    rig.fcu.answers['PARAM_REQUEST_LIST'] = lambda _m: [param_value(i) for i in range(len(PARAMS))
                                                        if i not in lost]
    rig.fcu.answers['PARAM_REQUEST_READ'] = lambda m: [param_value(m.param_index)]
    response = rig.call('~param/pull', ParamPullRequest())
    assert (response.success, response.param_received) == (True, 5)
    reads = rig.fcu.got('PARAM_REQUEST_READ')
    assert sorted(m.param_index for m in reads) == [2, 4], 'only the missing indices are re-read'
    assert all((m.target_system, m.target_component) == (1, 1) for m in reads)
    got = rig.call('~param/get', ParamGetRequest(param_id='COM_RCL_EXCEPT'))
    assert got.success and got.value.integer == 4
    assert rig.call('~param/get', ParamGetRequest(param_id='NAV_DLL_ACT')).value.integer == -1
    assert rig.call('~param/get', ParamGetRequest(param_id='MIS_TAKEOFF_ALT')).value.real == 2.5
    assert not rig.call('~param/get', ParamGetRequest(param_id='NO_SUCH_PARAM')).success


def test_param_set_sends_an_integer_bytewise_and_waits_for_the_echo():
    rig = Rig(param.Param)
    rig.fcu.send(param_value(2))
    rig.fcu.answers['PARAM_SET'] = lambda m: [BUILD.param_value_encode(m.param_id.encode(), m.param_value,
                                                                             m.param_type, len(PARAMS), 2)]
    request = ParamSetRequest(param_id='COM_RCL_EXCEPT')
    request.value.integer = 7
    response = rig.call('~param/set', request)
    assert response.success and response.value.integer == 7
    [sent] = rig.fcu.got('PARAM_SET')
    assert sent.param_type == mavlink.MAV_PARAM_TYPE_INT32
    assert struct.pack('<f', sent.param_value) == struct.pack('<i', 7)


@pytest.mark.parametrize('param_id, field, value, on_wire', [
    ('COM_RCL_EXCEPT', 'integer', 4294967297, int32_on_wire(1)),          # static_cast<int>: the low 32 bits
    ('COM_RCL_EXCEPT', 'integer', -4294967295, int32_on_wire(1)),
    ('COM_RCL_EXCEPT', 'real', 1e12, int32_on_wire(-2 ** 31)),            # int32_t(double) out of range on x86
    ('MPC_XY_VEL_MAX', 'real', 1e40, math.inf)])                          # a double beyond float: inf
def test_param_set_of_a_value_the_wire_cannot_hold_answers_and_sends_what_mavros_casts(param_id, field, value,
                                                                                       on_wire, caplog):
    rig = Rig(param.Param)
    index = [name for name, _kind, _value in PARAMS].index(param_id)
    rig.fcu.send(param_value(index))
    rig.fcu.answers['PARAM_SET'] = lambda m: [BUILD.param_value_encode(m.param_id.encode(), m.param_value,
                                                                             m.param_type, len(PARAMS), index)]
    request = ParamSetRequest(param_id=param_id)
    setattr(request.value, field, value)
    response = rig.call('~param/set', request)
    [sent] = rig.fcu.got('PARAM_SET')
    assert struct.pack('<f', sent.param_value) == struct.pack('<f', on_wire)
    assert response.value.integer or response.value.real, 'answered with the FCU\'s echo'
    assert any(param_id in r.getMessage() and 'value.' + field in r.getMessage() for r in caplog.records
               if r.levelname == 'WARNING'), 'a warning names the field'


def answer_read(m):
    """The FCU's answer to PARAM_REQUEST_READ: by index, or by name (index -1); nothing if unknown."""
    names = [name for name, _kind, _value in PARAMS]
    index = m.param_index if m.param_index >= 0 else (names.index(m.param_id) if m.param_id in names else None)
    return [] if index is None else [param_value(index)]


def test_param_pull_mirrors_the_list_into_ros_parameters_as_mavros(monkeypatch):
    """After ~param/pull, `rosparam get /mavros/param/MPC_XY_VEL_MAX` finds the FCU's value, as with mavros:
    an int for an INT32 parameter, a float for a REAL32 one, PX4's _HASH_CHECK left out."""
    monkeypatch.setattr(param, 'LIST_TIMEOUT_S', 2.0)
    rig = Rig(param.Param)
    hash_check = BUILD.param_value_encode(b'_HASH_CHECK', int32_on_wire(-123456), mavlink.MAV_PARAM_TYPE_INT32,
                                          len(PARAMS) + 1, len(PARAMS))
    rig.fcu.answers['PARAM_REQUEST_LIST'] = lambda _m: [param_value(i, len(PARAMS) + 1)
                                                        for i in range(len(PARAMS))] + [hash_check]
    rig.fcu.send(param_value(1))  # the pull after connection has not run: nothing is mirrored yet
    assert rig.ros.get_param('~param', None) is None, 'mavros mirrors on ~param/pull and ~param/set only'
    assert rig.call('~param/pull', ParamPullRequest()).success
    mirrored = rig.ros.get_param('~param', {})
    assert mirrored == {'MAV_SYS_ID': 1, 'MPC_XY_VEL_MAX': 12.0, 'COM_RCL_EXCEPT': 4, 'NAV_DLL_ACT': -1,
                        'MIS_TAKEOFF_ALT': 2.5}
    assert [type(mirrored[name]) for name in ('COM_RCL_EXCEPT', 'MPC_XY_VEL_MAX')] == [int, float]


def test_param_set_mirrors_the_echoed_value(monkeypatch):
    rig = param_fcu_rig(monkeypatch)
    request = ParamSetRequest(param_id='COM_RCL_EXCEPT')
    request.value.integer = 7
    assert rig.call('~param/set', request).success
    assert rig.ros.get_param('~param/COM_RCL_EXCEPT', None) == 7
    rig.fcu.answers['PARAM_SET'] = lambda _m: []  # an FCU that stops echoing: its last value stays mirrored
    monkeypatch.setattr(param, 'SET_TIMEOUT_S', 0.05)
    request.value.integer = 9
    sent_before = len(rig.fcu.got('PARAM_SET'))
    assert not rig.call('~param/set', request).success
    assert rig.ros.get_param('~param/COM_RCL_EXCEPT', None) == 7
    assert len(rig.fcu.got('PARAM_SET')) - sent_before == mavros_figure('param', 'param_set_sends'), \
        'as often as mavros sends an unechoed PARAM_SET'


def test_mission_and_param_timing_is_mavros_1_21s():
    """The waits the offline tests shorten: mavros's own, as its source sets them."""
    assert (mission.STEP_TIMEOUT_S, mission.PULL_AFTER_CONNECT_S) == (
        mavros_figure('mission', 'step_timeout_s'), mavros_figure('mission', 'pull_after_connect_s'))
    assert (param.SET_TIMEOUT_S, param.READ_TIMEOUT_S, param.PULL_AFTER_CONNECT_S, param.LIST_TIMEOUT_S) == (
        mavros_figure('param', 'param_timeout_s'), mavros_figure('param', 'param_timeout_s'),
        mavros_figure('param', 'pull_after_connect_s'), mavros_figure('param', 'list_timeout_s'))


def test_param_push_reads_back_what_the_pull_mirrored_and_skips_mavros_s_excluded_ids(monkeypatch):
    from mavros_msgs.srv import ParamPushRequest
    rig = param_fcu_rig(monkeypatch)
    rig.ros.params['~param'] = {'COM_RCL_EXCEPT': 4}
    rig.call('~param/get', ParamGetRequest(param_id='COM_RCL_EXCEPT'))
    rig.ros.set_param('~param/COM_RCL_EXCEPT', 6)  # `rosparam set /mavros/param/COM_RCL_EXCEPT 6`
    rig.ros.set_param('~param/STAT_BOOTCNT', 3)
    res = rig.call('~param/push', ParamPushRequest())
    assert (res.success, res.param_transfered) == (True, 1)
    assert [m.param_id for m in rig.fcu.got('PARAM_SET')] == ['COM_RCL_EXCEPT'], 'STAT_BOOTCNT is never pushed'


def param_fcu_rig(monkeypatch):
    """A connected bridge with the param plugin, before any pull; the FCU answers reads (by index
    or name) and echoes sets."""
    monkeypatch.setattr(param, 'READ_TIMEOUT_S', 0.05)
    rig = Rig(param.Param)
    rig.bridge.connected = True
    rig.fcu.answers['PARAM_REQUEST_READ'] = answer_read
    rig.fcu.answers['PARAM_SET'] = lambda m: [BUILD.param_value_encode(m.param_id.encode(), m.param_value,
                                                                             m.param_type, len(PARAMS), 0)]
    return rig


def test_param_get_and_set_before_the_pull_read_from_the_fcu(monkeypatch):
    """PX4's posctl test sets COM_RCL_EXCEPT right after start: before the 10 s pull, the bridge
    reads that parameter by name instead of answering false as mavros does."""
    rig = param_fcu_rig(monkeypatch)
    got = rig.call('~param/get', ParamGetRequest(param_id='MPC_XY_VEL_MAX'))
    assert got.success and got.value.real == 12.0
    [read] = rig.fcu.got('PARAM_REQUEST_READ')
    assert (read.param_id, read.param_index) == ('MPC_XY_VEL_MAX', -1) and rig.fcu.got('PARAM_REQUEST_LIST') == []
    request = ParamSetRequest(param_id='COM_RCL_EXCEPT')
    request.value.integer = 4
    response = rig.call('~param/set', request)
    assert response.success and response.value.integer == 4
    [sent] = rig.fcu.got('PARAM_SET')
    assert sent.param_type == mavlink.MAV_PARAM_TYPE_INT32, 'the type came from the FCU\'s answer'


def test_param_unknown_to_the_fcu_too_is_false_after_the_retries(monkeypatch):
    """A read by name is the bridge's own (mavros answers false before its pull); it gives up after as many
    reads as mavros spends on the first parameter missing from a pull."""
    rig = param_fcu_rig(monkeypatch)
    reads = mavros_figure('param', 'first_missing_index_reads')
    assert not rig.call('~param/get', ParamGetRequest(param_id='NO_SUCH_PARAM')).success
    assert len(rig.fcu.got('PARAM_REQUEST_READ')) == reads
    request = ParamSetRequest(param_id='NO_SUCH_PARAM')
    request.value.real = 1.0
    assert not rig.call('~param/set', request).success and rig.fcu.got('PARAM_SET') == []
    too_long = ParamGetRequest(param_id='A' * 17)
    assert not rig.call('~param/get', too_long).success
    assert len(rig.fcu.got('PARAM_REQUEST_READ')) == 2 * reads, 'a bad id is not sent'


def test_param_get_during_a_pull_waits_for_it(monkeypatch):
    monkeypatch.setattr(param, 'QUIET_S', 0.05)
    rig = Rig(param.Param)
    rig.bridge.connected = True
    release = threading.Event()

    def slow_list(_m):
        release.wait(2.0)
        return [param_value(i) for i in range(len(PARAMS))]
    rig.fcu.answers['PARAM_REQUEST_LIST'] = slow_list
    puller = threading.Thread(target=rig.call, args=('~param/pull', ParamPullRequest()))
    puller.start()
    assert wait_until(lambda: rig.plugin.pull_lock.locked(), 1.0)
    answer = []
    getter = threading.Thread(target=lambda: answer.append(rig.call('~param/get', ParamGetRequest(
        param_id='NAV_DLL_ACT'))))
    getter.start()
    time.sleep(0.1)
    assert not answer, 'the get waits while the pull is under way'
    release.set()
    puller.join(3.0)
    getter.join(3.0)
    assert answer[0].success and answer[0].value.integer == -1
    assert rig.fcu.got('PARAM_REQUEST_READ') == [], 'the pull brought it: no extra read'


# -- attitude, imu, local_position ---------------------------------------------------------------

def test_attitude_is_converted_once_and_shared_by_imu_and_local_position(monkeypatch):
    conversions = []
    convert = frames.orientation_ned_to_enu
    monkeypatch.setattr(frames, 'orientation_ned_to_enu', lambda q: conversions.append(q) or convert(q))
    rig = Rig(local_position.LocalPosition, imu.Imu)
    # facing north in NED (identity), rolling at 0.1, pitching at 0.2, yawing at 0.3 rad/s (FRD)
    rig.fcu.send(BUILD.attitude_quaternion_encode(0, 1.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3))
    assert len(conversions) == 1
    [data] = rig.published('~imu/data')
    north_in_enu = (0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5))   # yaw +90 deg about ENU z
    assert same_rotation((data.orientation.x, data.orientation.y, data.orientation.z, data.orientation.w),
                         north_in_enu)
    w = data.angular_velocity
    assert (w.x, w.y, w.z) == pytest.approx((0.1, -0.2, -0.3)), 'body rates FRD -> FLU'
    rig.fcu.send(BUILD.local_position_ned_encode(0, 1.0, 2.0, -3.0, 0.5, 0.0, 0.0))
    [pose] = rig.published('~local_position/pose')
    p, q = pose.pose.position, pose.pose.orientation
    assert (p.x, p.y, p.z) == pytest.approx((2.0, 1.0, 3.0))
    assert same_rotation((q.x, q.y, q.z, q.w), north_in_enu)
    [twist] = rig.published('~local_position/velocity_local')
    lin, ang = twist.twist.linear, twist.twist.angular
    assert (lin.x, lin.y, lin.z) == pytest.approx((0.0, 0.5, 0.0))
    # roll about the nose (north: ENU y), pitch about the right wing (east: ENU x), yaw about down
    assert (ang.x, ang.y, ang.z) == pytest.approx((0.2, 0.1, -0.3))
    assert len(conversions) == 1


def _highres(fields_updated, **values):
    fields = dict(time_usec=2000000, xacc=0.5, yacc=0.25, zacc=-9.75, xgyro=0.1, ygyro=0.2, zgyro=0.3, xmag=0.21,
                  ymag=0.0, zmag=0.43, abs_pressure=955.57, diff_pressure=0.0, pressure_alt=488.0, temperature=15.0)
    fields.update(values)
    return BUILD.highres_imu_encode(fields_updated=fields_updated, **fields)


@pytest.mark.parametrize('fields_updated, topics', [
    (0x3F, {'~imu/data_raw'}),                                                 # PX4 SIH's most messages
    (0x1FF, {'~imu/data_raw', '~imu/mag'}),                                    # ... with the magnetometer
    (0x1A3F, {'~imu/data_raw', '~imu/static_pressure', '~imu/temperature_imu'}),  # ... with the barometer
    (0x400, {'~imu/diff_pressure'}),
    (0x0, set()),
])
def test_highres_imu_publishes_what_its_fields_updated_says_is_fresh(fields_updated, topics):
    """mavros 1.21's imu plugin: data_raw when the accelerometer or gyro is fresh, mag when the
    magnetometer is, static_pressure, diff_pressure and temperature_imu when theirs are; nothing else."""
    rig = Rig(imu.Imu)
    rig.fcu.send(_highres(fields_updated, diff_pressure=1.5))
    published = {topic for topic in ('~imu/data_raw', '~imu/mag', '~imu/static_pressure', '~imu/diff_pressure',
                                     '~imu/temperature_imu', '~imu/temperature_baro') if rig.published(topic)}
    assert published == topics
    if '~imu/static_pressure' in topics:
        [pressure] = rig.published('~imu/static_pressure')
        assert pressure.fluid_pressure == pytest.approx(955.57), 'hPa, unconverted, as mavros 1.21 publishes it'
        assert rig.published('~imu/temperature_imu')[0].temperature == 15.0
    if '~imu/diff_pressure' in topics:
        assert rig.published('~imu/diff_pressure')[0].fluid_pressure == pytest.approx(1.5)


def test_imu_covariances_are_mavros_s_from_the_standard_deviations():
    """px4_config.yaml's deviations (mavros's defaults): squared on the diagonal; 0 (the magnetometer's)
    is unknown, element 0 -1; imu/data's acceleration is unknown until a HIGHRES_IMU has carried one."""
    rig = Rig(imu.Imu)
    rig.fcu.send(BUILD.attitude_quaternion_encode(0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    [before] = rig.published('~imu/data')
    assert before.linear_acceleration_covariance[0] == -1.0
    assert before.linear_acceleration_covariance[4] == pytest.approx(0.0003 ** 2)
    rig.fcu.send(_highres(0x1FF))
    rig.fcu.send(BUILD.attitude_quaternion_encode(20, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    data = rig.published('~imu/data')[-1]
    gyro_var = math.radians(0.02) ** 2
    assert list(data.orientation_covariance) == pytest.approx([1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0])
    assert list(data.angular_velocity_covariance) == pytest.approx([gyro_var, 0, 0, 0, gyro_var, 0, 0, 0, gyro_var])
    assert list(data.linear_acceleration_covariance) == pytest.approx([9e-8, 0, 0, 0, 9e-8, 0, 0, 0, 9e-8])
    a = data.linear_acceleration
    assert (a.x, a.y, a.z) == pytest.approx((0.5, -0.25, 9.75))
    [raw] = rig.published('~imu/data_raw')
    assert list(raw.orientation_covariance) == [-1.0] + [0.0] * 8
    assert list(raw.angular_velocity_covariance) == list(data.angular_velocity_covariance)
    [mag] = rig.published('~imu/mag')
    assert list(mag.magnetic_field_covariance) == [-1.0] + [0.0] * 8
    assert (mag.magnetic_field.x, mag.magnetic_field.z) == pytest.approx((0.21e-4, -0.43e-4))


def test_imu_deviations_from_parameters_and_a_string_is_mavros_s_default_with_a_warning(caplog):
    rig = Rig(imu.Imu, imu__linear_acceleration_stdev=0.5, imu__magnetic_stdev=0.1, imu__frame_id='imu_link',
              imu__angular_velocity_stdev='0.0003490659 // 0.02 degrees')  # px4_config.yaml's, a string in YAML
    assert 'imu/angular_velocity_stdev' in caplog.text and 'not a number' in caplog.text
    rig.fcu.send(_highres(0x1FF))
    [raw] = rig.published('~imu/data_raw')
    assert raw.header.frame_id == 'imu_link'
    assert raw.linear_acceleration_covariance[0] == pytest.approx(0.25)
    assert raw.angular_velocity_covariance[0] == pytest.approx(math.radians(0.02) ** 2)
    assert rig.published('~imu/mag')[0].magnetic_field_covariance[8] == pytest.approx(0.01)
    with pytest.raises(ConfigError, match=r'~imu/orientation_stdev: -1 is outside'):
        Rig(imu.Imu, imu__orientation_stdev=-1.0)


def test_pose_orientation_is_identity_before_any_attitude():
    rig = Rig(local_position.LocalPosition)
    rig.fcu.send(BUILD.local_position_ned_encode(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    q = rig.published('~local_position/pose')[0].pose.orientation
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)


def test_unneeded_types_are_not_decoded_and_a_subscriber_brings_them_back(monkeypatch):
    """On the real link: with no subscriber to what LOCAL_POSITION_NED and GLOBAL_POSITION_INT feed
    (the latter after the map origin), their frames are checked and counted but not decoded; a
    subscriber gets the very next message. ATTITUDE_QUATERNION and HIGHRES_IMU frames are always
    kept, and decoded only when read: the first pose or IMU message a new subscriber gets must carry
    the attitude and acceleration of now, and on PX4's wire (a datagram per message) they came before."""
    from offboard_py.mavlink_link import MavlinkLink
    link = MavlinkLink(('127.0.0.1', 0), None, 1, mavlink.MAV_COMP_ID_UDP_BRIDGE, peer=(1, 1))
    ros = FakeRos()
    bridge = Bridge(read_config(lambda name, default: default), link, ros, node.PLUGINS, clock=FakeClock())
    for publisher in ros.topics.values():
        publisher.connections = 0
    decoded = []
    from offboard_py import wire
    real_decode = wire.decode
    monkeypatch.setattr(wire, 'decode', lambda msg_id, frame: decoded.append(msg_id) or real_decode(msg_id, frame))
    fcu = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    gps = BUILD.gps_raw_int_encode(0, 3, 473977420, 85455940, 488000, 70, 110, 0, 0, 10)
    gpi = BUILD.global_position_int_encode(0, 473977420, 85455940, 488000, 0, 0, 0, 0, 0)
    north = BUILD.attitude_quaternion_encode(1000, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    south = BUILD.attitude_quaternion_encode(1020, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    lpn = BUILD.local_position_ned_encode(1040, 1.0, 2.0, -3.0, 0.0, 0.0, 0.0)

    def datagram(*msgs):
        link.handle_datagram(b''.join(msg.pack(fcu) for msg in msgs), ('127.0.0.1', 14580))

    datagram(gps, gpi)
    gp = next(plugin for plugin in bridge.plugins if isinstance(plugin, global_position.GlobalPosition))
    assert gp.origin is not None, 'GLOBAL_POSITION_INT is read until the map origin is known'
    late = []
    decode_checked = wire.decode_checked
    monkeypatch.setattr(wire, 'decode_checked', lambda frame: late.append(frame) or decode_checked(frame))
    del decoded[:]
    accel = BUILD.highres_imu_encode(1010, 0.5, 0.25, -9.75, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, HIGHRES_IMU_UPDATED_ACCEL_GYRO)
    datagram(north)
    datagram(accel)
    datagram(south)  # the attitude of now, while nobody listens
    assert decoded == [] and late == [], 'attitude and IMU frames kept, not decoded, while nobody reads them'
    received = link.stats['received']
    datagram(lpn, gpi)
    assert decoded == [] and link.stats['received'] == received + 2 and link.stats['bad_frames'] == 0
    assert ros.topics['~local_position/pose'].messages == []
    ros.topics['~local_position/pose'].connections = 1
    datagram(lpn)
    assert decoded == [mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED]
    [pose] = ros.topics['~local_position/pose'].messages
    q = pose.pose.orientation
    assert same_rotation((q.x, q.y, q.z, q.w), (0.0, 0.0, -math.sqrt(0.5), math.sqrt(0.5))), \
        'facing south (yaw -90 deg in ENU), the latest attitude, though it came before the subscriber'
    assert len(late) == 1, 'the kept attitude decoded once, when read'
    ros.topics['~imu/data'].connections = 1
    datagram(south)
    [data] = ros.topics['~imu/data'].messages
    a = data.linear_acceleration
    assert (a.x, a.y, a.z) == pytest.approx((0.5, -0.25, 9.75)), 'the kept HIGHRES_IMU\'s acceleration, FRD -> FLU'
    link.close()


# -- setpoint ----------------------------------------------------------------------------------

def test_setpoint_position_goes_out_as_position_and_yaw_in_ned():
    rig = Rig(setpoint.Setpoint)
    pose = PoseStamped()
    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = 1.0, 2.0, 3.0
    pose.pose.orientation.w = 1.0   # facing east (ENU yaw 0)
    rig.ros.subscriptions['~setpoint_position/local'](pose)
    [sent] = rig.fcu.got('SET_POSITION_TARGET_LOCAL_NED')
    assert (sent.coordinate_frame, sent.type_mask) == (mavlink.MAV_FRAME_LOCAL_NED, 0x9F8)
    assert (sent.x, sent.y, sent.z, sent.yaw) == pytest.approx((2.0, 1.0, -3.0, math.pi / 2))
    pose.pose.position.x = float('nan')
    rig.ros.subscriptions['~setpoint_position/local'](pose)
    assert len(rig.fcu.got('SET_POSITION_TARGET_LOCAL_NED')) == 1 and rig.plugin.rejected == 1


def test_setpoint_position_takes_the_rotation_mavros_takes_from_an_unnormalised_quaternion():
    """The PX4 tutorial's pose leaves the orientation all zero: mavros's Eigen makes it the identity
    (facing east, NED yaw +90 deg). A 90 deg yaw quaternion of length sqrt(1/2) turns by 45 deg there
    (ENU yaw 45 deg, NED yaw 45 deg)."""
    rig = Rig(setpoint.Setpoint)
    pose = PoseStamped()
    pose.pose.position.z = 2.0
    rig.ros.subscriptions['~setpoint_position/local'](pose)
    pose.pose.orientation.z, pose.pose.orientation.w = 0.5, 0.5
    rig.ros.subscriptions['~setpoint_position/local'](pose)
    yaws = [m.yaw for m in rig.fcu.got('SET_POSITION_TARGET_LOCAL_NED')]
    assert yaws == pytest.approx([math.pi / 2, math.pi / 4])


@pytest.mark.parametrize('frame', [mavlink.MAV_FRAME_BODY_NED, mavlink.MAV_FRAME_BODY_OFFSET_NED])
def test_setpoint_raw_local_in_a_body_frame_negates_yaw_and_flips_y_and_z(frame):
    """mavros sends a body frame's yaw as the yaw of q_x(pi) * q_yaw, -yaw (not the world's pi/2 - yaw),
    and its vectors FLU -> FRD."""
    from mavros_msgs.msg import PositionTarget
    rig = Rig(setpoint.Setpoint)
    msg = PositionTarget(coordinate_frame=frame, type_mask=0)
    msg.position.x, msg.position.y, msg.position.z = 1.0, 2.0, 3.0
    msg.velocity.x, msg.velocity.y, msg.velocity.z = 0.1, 0.2, 0.3
    msg.acceleration_or_force.x, msg.acceleration_or_force.y, msg.acceleration_or_force.z = 0.4, 0.5, 0.6
    msg.yaw, msg.yaw_rate = 0.3, 0.2
    rig.ros.subscriptions['~setpoint_raw/local'](msg)
    [sent] = rig.fcu.got('SET_POSITION_TARGET_LOCAL_NED')
    assert sent.coordinate_frame == frame
    assert (sent.x, sent.y, sent.z, sent.vx, sent.vy, sent.vz, sent.afx, sent.afy, sent.afz) == pytest.approx(
        (1.0, -2.0, -3.0, 0.1, -0.2, -0.3, 0.4, -0.5, -0.6))
    assert (sent.yaw, sent.yaw_rate) == pytest.approx((-0.3, -0.2))
    msg.coordinate_frame = mavlink.MAV_FRAME_LOCAL_NED
    rig.ros.subscriptions['~setpoint_raw/local'](msg)
    assert rig.fcu.got('SET_POSITION_TARGET_LOCAL_NED')[-1].yaw == pytest.approx(math.pi / 2 - 0.3), 'world: pi/2 - yaw'


# -- the topics mavros users reach for: global position, raw GPS, odometry, battery, targets ------

HOME_E7 = (473977420, 85455940)


def test_global_fix_status_comes_from_gps_raw_int_and_local_starts_at_the_first_fix():
    rig = Rig(global_position.GlobalPosition)
    gpi = BUILD.global_position_int_encode(1000, HOME_E7[0], HOME_E7[1], 488000, 0, 100, -200, 0, 9000)
    rig.fcu.send(gpi)
    [fix] = rig.published('~global_position/global')
    assert fix.status.status == -1, 'no GPS_RAW_INT yet: no fix, as mavros without GPS_RAW_INT'
    assert rig.published('~global_position/local') == [], 'no map origin without a fix'
    assert rig.published('~global_position/rel_alt')[-1].data == 0.0
    assert rig.published('~global_position/compass_hdg')[-1].data == 90.0
    rig.fcu.send(BUILD.gps_raw_int_encode(1000000, 3, HOME_E7[0], HOME_E7[1], 488000, 70, 110, 150, 9000, 10))
    raw = rig.published('~global_position/raw/fix')[-1]
    assert (raw.status.status, raw.status.service) == (0, 1)
    # as mavros 1.21: no receiver accuracies (h_acc, v_acc 0) -> EPH and EPV (times gps_uere 1.0) squared
    assert list(raw.position_covariance) == pytest.approx([0.49, 0, 0, 0, 0.49, 0, 0, 0, 1.21])
    assert raw.position_covariance_type == raw.COVARIANCE_TYPE_APPROXIMATED
    assert raw.header.frame_id == 'base_link', 'mavros 1.21 stamps its fixes with the child frame'
    vel = rig.published('~global_position/raw/gps_vel')[-1].twist.linear
    assert (vel.x, vel.y) == pytest.approx((1.5, 0.0), abs=1e-9), 'course 90 deg: east'
    assert rig.published('~global_position/raw/satellites')[-1].data == 10
    rig.fcu.send(gpi)  # the first position with a fix is the origin
    north_10m = HOME_E7[0] + int(round(10.0 / 111194.9 * 1e7))
    rig.fcu.send(BUILD.global_position_int_encode(2000, north_10m, HOME_E7[1], 493000, 4000, 100, -200, 50, 9000))
    fix = rig.published('~global_position/global')[-1]
    assert (fix.status.status, fix.header.frame_id) == (0, 'base_link')
    assert list(fix.position_covariance) == list(raw.position_covariance), 'the latest raw fix\'s covariance'
    odom = rig.published('~global_position/local')[-1]
    p, v = odom.pose.pose.position, odom.twist.twist.linear
    # z: the height above home (use_relative_alt), 4 m, though 5 m above the origin's altitude
    assert (p.x, p.y, p.z) == pytest.approx((0.0, 10.0, 4.0), abs=0.05)
    # as mavros 1.21: east and north from NED's vy and vx, vz as it comes (0.5 m/s down stays +0.5)
    assert (v.x, v.y, v.z) == pytest.approx((-2.0, 1.0, 0.5))
    assert odom.pose.covariance[0] == pytest.approx(0.49) and odom.pose.covariance[14] == pytest.approx(1.21)
    assert (odom.pose.covariance[21], odom.pose.covariance[35]) == (99999.0, 99999.0)
    assert odom.twist.covariance[0] == -1.0
    assert rig.published('~global_position/rel_alt')[-1].data == 4.0


def test_raw_fix_covariance_is_the_receivers_accuracy_when_it_gives_one_and_a_2d_fix_is_no_fix():
    """Real mavros 1.21 on PX4 SITL's replayed GPS_RAW_INT (h_acc 900 mm, v_acc 1780 mm) published
    [0.81, .., 0.81, .., 3.1684], type 2 (bench/results/2026-11-25-mavros-side-by-side.md); it reads
    fix_type > 2 as a fix, so a 2D fix is none; with neither accuracy nor EPH/EPV the covariance is unknown."""
    rig = Rig(global_position.GlobalPosition)
    rig.fcu.send(BUILD.gps_raw_int_encode(1000000, 3, HOME_E7[0], HOME_E7[1], 488000, 70, 110, 0, 0, 10,
                                          h_acc=900, v_acc=1780))
    raw = rig.published('~global_position/raw/fix')[-1]
    assert list(raw.position_covariance) == pytest.approx([0.81, 0, 0, 0, 0.81, 0, 0, 0, 3.1684])
    assert raw.position_covariance_type == raw.COVARIANCE_TYPE_DIAGONAL_KNOWN
    rig.fcu.send(BUILD.gps_raw_int_encode(1000000, 2, HOME_E7[0], HOME_E7[1], 488000, 0xFFFF, 0xFFFF, 0, 0, 4))
    raw = rig.published('~global_position/raw/fix')[-1]
    assert raw.status.status == raw.status.STATUS_NO_FIX
    assert (list(raw.position_covariance), raw.position_covariance_type) == ([-1.0] + [0.0] * 8,
                                                                             raw.COVARIANCE_TYPE_UNKNOWN)


def test_odom_velocity_body_and_tf_from_local_position():
    rig = Rig(local_position.LocalPosition, local_position__tf__send=True)
    # facing east in NED (yaw +90 deg), flying east at 2 m/s
    rig.fcu.send(BUILD.attitude_quaternion_encode(0, math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5), 0.0, 0.0, 0.0))
    rig.fcu.send(BUILD.local_position_ned_encode(0, 1.0, 2.0, -3.0, 0.0, 2.0, 0.0))
    odom = rig.published('~local_position/odom')[-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ('map', 'base_link')
    # mavros 1.21 stamps both velocities with the child frame, the local one's vector in map axes all the same
    assert rig.published('~local_position/velocity_local')[-1].header.frame_id == 'base_link'
    assert rig.published('~local_position/velocity_body')[-1].header.frame_id == 'base_link'
    p = odom.pose.pose.position
    assert (p.x, p.y, p.z) == (2.0, 1.0, 3.0)
    lin = odom.twist.twist.linear
    assert (lin.x, lin.y, lin.z) == pytest.approx((2.0, 0.0, 0.0), abs=1e-6), 'facing east, flying east: forward'
    [tf] = rig.published('/tf')
    [t] = tf.transforms
    assert (t.header.frame_id, t.child_frame_id) == ('map', 'base_link')
    assert (t.transform.translation.x, t.transform.translation.y, t.transform.translation.z) == (2.0, 1.0, 3.0)


def test_battery_from_sys_status_until_battery_status_arrives():
    from offboard_py.bridge import battery
    rig = Rig(battery.Battery)
    rig.fcu.send(BUILD.sys_status_encode(0, 0, 0, 137, 16200, -100, 100, 0, 0, 0, 0, 0, 0))
    b = rig.published('~battery')[-1]
    assert (b.voltage, b.current, b.percentage) == pytest.approx((16.2, 1.0, 1.0)) and b.present
    cells = [4050] * 4 + [0xFFFF] * 6
    rig.fcu.send(BUILD.battery_status_encode(0, 1, 1, 2500, cells, 500, 0, 0, 90))
    b = rig.published('~battery')[-1]
    assert b.voltage == pytest.approx(16.2) and list(b.cell_voltage) == pytest.approx([4.05] * 4)
    assert (b.current, b.percentage, b.temperature) == pytest.approx((-5.0, 0.9, 0.0))  # mavros fills none
    count = len(rig.published('~battery'))
    rig.fcu.send(BUILD.sys_status_encode(0, 0, 0, 137, 16200, -100, 100, 0, 0, 0, 0, 0, 0))
    assert len(rig.published('~battery')) == count, 'BATTERY_STATUS wins over SYS_STATUS'


def test_system_and_battery_statuses_as_mavros():
    """mavros's System status from PX4 SITL's recorded SYS_STATUS (reference/px4-sitl-measured.md: present
    0x0300402F, enabled 0x0301402F, health 0x1320C83F: the RC receiver enabled and not healthy, so
    'Sensor health' at ERROR, as real mavros shows it), and its Battery status: 'No data' before any,
    under sys/min_voltage (10 V) 'Low voltage', each cell once there are several."""
    from offboard_py.bridge import battery, diagnostics

    def statuses(rig, at_s):
        rig.tick(at_s)
        return {s.name: (s.level, s.message, [(kv.key, kv.value) for kv in s.values])
                for s in rig.published('/diagnostics')[-1].status}
    rig = Rig(sys_status.SysStatus, battery.Battery, diagnostics.Diagnostics)
    start_s = rig.clock.now_s
    first = statuses(rig, start_s + 1.0)
    assert first['mavros: System'][:2] == (0, 'Normal') and first['mavros: Battery'][:2] == (2, 'No data')
    assert first['mavros: Battery'][2] == [('Voltage', '-1.00'), ('Current', '0.0'), ('Remaining', '0.0')]
    rig.fcu.send(BUILD.sys_status_encode(0x0300402F, 0x0301402F, 0x1320C83F, 137, 9800, -100, 40, 0, 0, 0, 0, 0, 0))
    now = statuses(rig, start_s + 2.5)
    level, message, values = now['mavros: System']
    assert (level, message) == (2, 'Sensor health')
    assert values[:3] == [('Sensor present', '0x0300402F'), ('Sensor enabled', '0x0301402F'),
                          ('Sensor health', '0x1320C83F')]
    assert values[3:12] == [('3D gyro', 'Ok'), ('3D accelerometer', 'Ok'), ('3D magnetometer', 'Ok'),
                            ('absolute pressure', 'Ok'), ('GPS', 'Ok'), ('x/y position control', 'Ok'),
                            ('RC receiver', 'Fail'), ('Logging', 'Ok'), ('Battery', 'Ok')]
    assert values[12:15] == [('CPU Load (%)', '13.7'), ('Drop rate (%)', '0.0'), ('Errors comm', '0')]
    assert now['mavros: Battery'][:2] == (1, 'Low voltage'), '9.8 V, under mavros\'s 10 V'
    cells = [4050] * 4 + [0xFFFF] * 6
    rig.fcu.send(BUILD.battery_status_encode(0, 1, 1, 2500, cells, 500, 0, 0, 90))
    level, message, values = statuses(rig, start_s + 4.0)['mavros: Battery']
    assert (level, message) == (0, 'Normal')
    assert values[3:] == [('Cell %d' % i, '4.05') for i in range(1, 5)]
    assert 'mavros: System' not in statuses(Rig(sys_status.SysStatus, diagnostics.Diagnostics,
                                                 sys__disable_diag=True), start_s + 1.0)


def test_cmd_vel_goes_out_as_velocity_and_yaw_rate_and_target_local_comes_back_enu():
    from geometry_msgs.msg import Twist
    rig = Rig(setpoint.Setpoint)
    twist = Twist()
    twist.linear.x, twist.linear.y, twist.linear.z, twist.angular.z = 1.0, 2.0, 0.5, 0.3
    rig.ros.subscriptions['~setpoint_velocity/cmd_vel_unstamped'](twist)
    [sent] = rig.fcu.got('SET_POSITION_TARGET_LOCAL_NED')
    assert sent.type_mask == 0x5C7 and sent.coordinate_frame == mavlink.MAV_FRAME_LOCAL_NED
    assert (sent.vx, sent.vy, sent.vz, sent.yaw_rate) == pytest.approx((2.0, 1.0, -0.5, -0.3))
    twist.linear.x = float('nan')
    rig.ros.subscriptions['~setpoint_velocity/cmd_vel_unstamped'](twist)
    assert len(rig.fcu.got('SET_POSITION_TARGET_LOCAL_NED')) == 1, 'NaN is refused'
    rig.fcu.send(BUILD.position_target_local_ned_encode(500, mavlink.MAV_FRAME_LOCAL_NED, 0x9F8, 1.0, 2.0, -3.0,
                                                        0, 0, 0, 0, 0, 0, 0.0, 0.0))
    target = rig.published('~setpoint_raw/target_local')[-1]
    assert (target.position.x, target.position.y, target.position.z) == (2.0, 1.0, 3.0)
    assert target.yaw == pytest.approx(math.pi / 2) and target.type_mask == 0x9F8


def test_diagnostics_say_what_mavros_says():
    from offboard_py.bridge import diagnostics
    rig = Rig(sys_status.SysStatus, global_position.GlobalPosition, diagnostics.Diagnostics)
    rig.tick(rig.clock.now_s + 1.0)
    [array] = rig.published('/diagnostics')
    by_name = {s.name: s for s in array.status}
    # in real mavros 1.21's order (its plugins' load order)
    assert [s.name for s in array.status] == ['mavros: FCU connection', 'mavros: GPS', 'mavros: Heartbeat',
                                              'mavros: System']
    assert (by_name['mavros: GPS'].level, by_name['mavros: GPS'].message) == (2, 'No satellites')
    fcu_link = by_name['mavros: FCU connection']
    assert (fcu_link.level, fcu_link.message) == (1, 'not connected'), 'mavros: warn while the link is open'
    assert [kv.key for kv in fcu_link.values] == [
        'Received packets:', 'Dropped packets:', 'Buffer overruns:', 'Parse errors:', 'Rx sequence number:',
        'Tx sequence number:', 'Rx total bytes:', 'Tx total bytes:', 'Rx speed:', 'Tx speed:']
    rig.fcu.send(heartbeat(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED))
    rig.fcu.send(BUILD.gps_raw_int_encode(1000000, 3, 473977420, 85455940, 488000, 70, 110, 0, 0, 10))
    rig.tick(rig.clock.now_s + 2.0)
    by_name = {s.name: s for s in rig.published('/diagnostics')[-1].status}
    gps = by_name['mavros: GPS']
    assert (gps.level, gps.message) == (0, '3D fix')
    assert {kv.key: kv.value for kv in gps.values}['EPH (m)'] == '0.70'
    assert (by_name['mavros: FCU connection'].level, by_name['mavros: Heartbeat'].level) == (0, 0)
    # mavros 1.21's HeartbeatStatus: its keys in its order, its enum strings (enum_to_string.cpp)
    values = [(kv.key, kv.value) for kv in by_name['mavros: Heartbeat'].values]
    assert [key for key, _ in values] == ['Heartbeats since startup', 'Frequency (Hz)', 'Vehicle type',
                                          'Autopilot type', 'Mode', 'System status']
    assert [value for key, value in values if key != 'Frequency (Hz)'] == [
        '1', 'Quadrotor', 'PX4 Autopilot', 'AUTO.LOITER', 'Standby']


def test_diagnostics_are_named_after_the_node_as_diagnostic_updater_names_them():
    """diagnostic_updater puts the node's name before each status (Updater::publish: the name without
    its leading slash): in a fleet, /uav3/mavros's say "uav3/mavros: ...", so each vehicle's can be told
    from the others' on the one /diagnostics topic."""
    from offboard_py.bridge import diagnostics
    rig = Rig(sys_status.SysStatus, diagnostics.Diagnostics, node_name='/uav3/mavros')
    rig.tick(rig.clock.now_s + 1.0)
    [array] = rig.published('/diagnostics')
    assert [s.name for s in array.status] == ['uav3/mavros: FCU connection', 'uav3/mavros: Heartbeat',
                                              'uav3/mavros: System']


def test_fcu_connection_status_counts_drops_and_speeds_as_mavconn():
    """mavconn's speeds: the bytes since the last status over its whole seconds; dropped packets are
    counted, and the summary stays mavros's (whose parser never counts a drop): no warning for them."""
    from offboard_py.bridge import diagnostics
    rig = Rig(diagnostics.Diagnostics)
    stats = rig.link.stats

    def fcu_link(at_s):
        rig.tick(at_s)
        status = {s.name: s for s in rig.published('/diagnostics')[-1].status}['mavros: FCU connection']
        return status.level, status.message, {kv.key: kv.value for kv in status.values}
    start_s = rig.clock.now_s
    stats['bytes_received'], stats['bytes_sent'] = 4000, 300
    level, message, values = fcu_link(start_s + 1.0)
    assert (values['Rx speed:'], values['Tx speed:']) == ('4000.000000', '300.000000')
    stats['bytes_received'] += 6000
    stats['dropped'] += 3
    level, message, values = fcu_link(start_s + 2.5)
    assert values['Rx speed:'] == '6000.000000', 'mavconn divides by whole seconds: 1.5 s is 1'
    assert (level, message, values['Dropped packets:']) == (1, 'not connected', '3')
    rig.bridge.connected = True
    assert fcu_link(start_s + 3.5)[:2] == (0, 'connected')


def test_heartbeat_status_counts_the_last_ten_periods_as_mavros():
    """mavros's HeartbeatStatus before any heartbeat (GENERIC, UNINIT, no mode), and 'No events
    recorded.' again only once ten diagnostics periods have passed without one, connected or not."""
    from offboard_py.bridge import diagnostics
    rig = Rig(sys_status.SysStatus, diagnostics.Diagnostics)

    def heartbeat_status(at_s):
        rig.tick(at_s)
        status = {s.name: s for s in rig.published('/diagnostics')[-1].status}['mavros: Heartbeat']
        return status.level, status.message, {kv.key: kv.value for kv in status.values}
    start_s = rig.clock.now_s
    level, message, values = heartbeat_status(start_s + 1.0)
    assert (level, message) == (2, 'No events recorded.')
    assert (values['Vehicle type'], values['Autopilot type'], values['System status'], values['Mode']) == (
        'Generic micro air vehicle', 'Generic autopilot', 'Uninit', '')
    for i in range(2, 12):  # a heartbeat a second for ten seconds
        rig.fcu.send(heartbeat(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED))
        level, message, values = heartbeat_status(start_s + i)
    assert (level, message, values['Heartbeats since startup']) == (0, 'Normal', '10')
    assert float(values['Frequency (Hz)']) == pytest.approx(1.0)
    for i in range(12, 21):  # then none: the last ten periods still hold some (the connection times out meanwhile)
        level, message, values = heartbeat_status(start_s + i)
        assert level != 2, 'only %d periods without a heartbeat' % (i - 11)
    assert (level, message) == (1, 'Frequency too low.'), 'one heartbeat in ten seconds: under 0.2 Hz'
    assert heartbeat_status(start_s + 21)[:2] == (2, 'No events recorded.')



# -- services: cmd/command, command_int, set_message_interval, set_stream_rate, param/push, set_current

def ack(m, result=mavlink.MAV_RESULT_ACCEPTED):
    return [BUILD.command_ack_encode(m.command, result)]


def test_cmd_command_waits_for_the_ack_unless_broadcast():
    from mavros_msgs.srv import CommandLongRequest
    rig = Rig(command.Command)
    rig.fcu.answers['COMMAND_LONG'] = lambda m: ack(m, mavlink.MAV_RESULT_DENIED) if m.target_system else []
    res = rig.call('~cmd/command', CommandLongRequest(command=mavlink.MAV_CMD_REQUEST_MESSAGE, param1=148.0))
    assert (res.success, res.result) == (False, mavlink.MAV_RESULT_DENIED)
    [sent] = rig.fcu.got('COMMAND_LONG')
    assert (sent.target_system, sent.command, sent.param1, sent.confirmation) == (1, 512, 148.0, 0)
    res = rig.call('~cmd/command', CommandLongRequest(broadcast=True, command=mavlink.MAV_CMD_REQUEST_MESSAGE,
                                                      confirmation=3))
    assert (res.success, res.result) == (True, mavlink.MAV_RESULT_ACCEPTED)
    last = rig.fcu.got('COMMAND_LONG')[-1]
    assert (last.target_system, last.target_component, last.confirmation) == (0, 0, 0), \
        'mavros sends a broadcast with confirmation 0 whatever the request says'


def test_cmd_set_home_and_command_ack_as_mavros():
    """cmd/set_home: MAV_CMD_DO_SET_HOME with confirmation 1, waiting for the ACK; cmd/command_ack: a
    COMMAND_ACK to the FCU, success and ACCEPTED once sent."""
    from mavros_msgs.srv import CommandAckRequest, CommandHomeRequest
    rig = Rig(command.Command)
    rig.fcu.answers['COMMAND_LONG'] = lambda m: ack(m, mavlink.MAV_RESULT_DENIED)
    res = rig.call('~cmd/set_home', CommandHomeRequest(current_gps=False, yaw=90.0, latitude=47.5, longitude=8.5,
                                                       altitude=500.0))
    assert (res.success, res.result) == (False, mavlink.MAV_RESULT_DENIED)
    res = rig.call('~cmd/set_home', CommandHomeRequest(current_gps=True))
    first, second = rig.fcu.got('COMMAND_LONG')
    assert (first.command, first.confirmation, first.param1, first.param4, first.param5, first.param6,
            first.param7) == (mavlink.MAV_CMD_DO_SET_HOME, 1, 0.0, 90.0, 47.5, 8.5, 500.0)
    assert second.param1 == 1.0
    res = rig.call('~cmd/command_ack', CommandAckRequest(command=mavlink.MAV_CMD_USER_1, result=mavlink.MAV_RESULT_DENIED,
                                                         progress=7, result_param2=-3 & 0xFFFFFFFF))
    assert (res.success, res.result) == (True, mavlink.MAV_RESULT_ACCEPTED)
    [sent] = rig.fcu.got('COMMAND_ACK')
    assert (sent.command, sent.result, sent.progress, sent.result_param2, sent.target_system,
            sent.target_component) == (mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_DENIED, 7, -3, 1, 1)


def test_cmd_command_int_sends_and_does_not_wait():
    from mavros_msgs.srv import CommandIntRequest
    rig = Rig(command.Command)
    req = CommandIntRequest(frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command=mavlink.MAV_CMD_DO_REPOSITION,
                            param1=-1.0, x=473977420, y=85455940, z=20.0)
    assert rig.call('~cmd/command_int', req).success
    [sent] = rig.fcu.got('COMMAND_INT')
    assert (sent.command, sent.x, sent.y, sent.z, sent.frame) == (192, 473977420, 85455940, 20.0, 6)


def test_set_message_interval_and_stream_rate():
    from mavros_msgs.srv import MessageIntervalRequest, StreamRateRequest
    rig = Rig(command.Command)
    rig.fcu.answers['COMMAND_LONG'] = ack
    assert rig.call('~set_message_interval', MessageIntervalRequest(message_id=30, message_rate=10.0)).success
    assert rig.call('~set_message_interval', MessageIntervalRequest(message_id=30, message_rate=-1.0)).success
    assert [(m.command, m.param1, m.param2) for m in rig.fcu.got('COMMAND_LONG')] == [
        (mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 30.0, 100000.0), (mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 30.0, -1.0)]
    # mavros's success is that its call to cmd/command went through: true with a refusal or no ACK at all
    rig.fcu.answers['COMMAND_LONG'] = lambda m: ack(m, mavlink.MAV_RESULT_DENIED)
    assert rig.call('~set_message_interval', MessageIntervalRequest(message_id=9999, message_rate=1.0)).success
    rig.fcu.answers['COMMAND_LONG'] = lambda m: []
    command_timeout = rig.plugin.timeout_s
    rig.plugin.timeout_s = 0.05
    assert rig.call('~set_message_interval', MessageIntervalRequest(message_id=30, message_rate=1.0)).success
    assert len(rig.fcu.got('COMMAND_LONG')) == 4, 'each call sent its command'
    rig.plugin.timeout_s = command_timeout
    rig.call('~set_stream_rate', StreamRateRequest(stream_id=0, message_rate=10, on_off=True))
    [stream] = rig.fcu.got('REQUEST_DATA_STREAM')
    assert (stream.req_stream_id, stream.req_message_rate, stream.start_stop) == (0, 10, 1)


def test_param_push_sets_every_known_parameter_and_answers_success_as_mavros(monkeypatch):
    """mavros's push_cb: each ~param the FCU has is set again, changed or not; an unknown one is
    warned of and not counted; the answer is success."""
    from mavros_msgs.srv import ParamPushRequest
    rig = param_fcu_rig(monkeypatch)
    rig.ros.params['~param'] = {'MPC_XY_VEL_MAX': 12.0, 'COM_RCL_EXCEPT': 5, 'NO_SUCH_PARAM': 1.0}
    res = rig.call('~param/push', ParamPushRequest())
    assert (res.success, res.param_transfered) == (True, 2), 'two set, one unknown to the FCU'
    assert [m.param_id for m in rig.fcu.got('PARAM_SET')] == ['COM_RCL_EXCEPT', 'MPC_XY_VEL_MAX']


def test_param_set_answers_success_for_any_echo_as_mavros(monkeypatch):
    """mavros's set_cb: success when the FCU echoed (send_param_set_and_wait), the value the echo's: a
    value the FCU kept (PX4 refusing it) comes back as success with the old value."""
    rig = param_fcu_rig(monkeypatch)
    rig.fcu.answers['PARAM_SET'] = lambda m: [param_value(2)]  # COM_RCL_EXCEPT stays 4
    request = ParamSetRequest(param_id='COM_RCL_EXCEPT')
    request.value.integer = 9
    response = rig.call('~param/set', request)
    assert response.success and response.value.integer == 4


def test_mission_set_current_waits_for_mission_current():
    from mavros_msgs.srv import WaypointSetCurrentRequest
    rig = Rig(mission.Mission)
    rig.fcu.answers['MISSION_SET_CURRENT'] = lambda m: [BUILD.mission_current_encode(m.seq)]
    assert rig.call('~mission/set_current', WaypointSetCurrentRequest(wp_seq=2)).success
    assert rig.fcu.got('MISSION_SET_CURRENT')[0].seq == 2



# -- statustext, vfr_hud, rc/in, estimator_status, attitude setpoints, raw MAVLink ---------------

def test_statustext_both_ways_vfr_hud_rc_in_and_estimator_status():
    from mavros_msgs.msg import StatusText
    from offboard_py.bridge import rc_io, statustext, vfr_hud
    rig = Rig(statustext.StatusTexts, vfr_hud.VfrHud, rc_io.RcIo, sys_status.SysStatus)
    rig.fcu.send(BUILD.statustext_encode(mavlink.MAV_SEVERITY_WARNING, b'Preflight Fail: baro'))
    text = rig.published('~statustext/recv')[-1]
    assert (text.severity, text.text) == (4, 'Preflight Fail: baro')
    rig.ros.subscriptions['~statustext/send'](StatusText(severity=6, text='hello PX4'))
    assert [(m.severity, m.text) for m in rig.fcu.got('STATUSTEXT')] == [(6, 'hello PX4')]
    rig.fcu.send(BUILD.vfr_hud_encode(0.5, 0.4, 90, 55, 490.2, -0.1))
    hud = rig.published('~vfr_hud')[-1]
    assert (hud.heading, hud.throttle, hud.altitude) == pytest.approx((90, 0.55, 490.2))
    rig.fcu.send(BUILD.rc_channels_encode(100, 4, 1500, 1500, 1000, 1500, *[0] * 14, 200))
    rc = rig.published('~rc/in')[-1]
    assert list(rc.channels) == [1500, 1500, 1000, 1500] and rc.rssi == 200
    rig.fcu.send(BUILD.estimator_status_encode(0, 1023, 0, 0, 0, 0, 0, 0, 0, 0))
    est = rig.published('~estimator_status')[-1]
    assert est.attitude_status_flag and est.const_pos_mode_status_flag and not est.gps_glitch_status_flag


def test_statustext_send_cuts_a_long_text_after_50_bytes_as_mavros(caplog):
    """mavros's set_string_z: the UTF-8 bytes, the first 50 sent, a warning from 50 bytes on; a long
    text is sent, not dropped, and a non-ASCII one goes as its UTF-8 bytes."""
    from mavros_msgs.msg import StatusText
    from offboard_py.bridge import statustext
    rig = Rig(statustext.StatusTexts)
    send = rig.ros.subscriptions['~statustext/send']
    send(StatusText(severity=4, text='x' * 49 + 'yz'))
    send(StatusText(severity=6, text='Höhe 5 m'))
    send(StatusText(severity=6, text='a' * 49 + 'é'))  # 51 bytes: the cut halves the é
    sent = rig.fcu.got('STATUSTEXT')
    # the text field's bytes as framed (MAVLink 2: 10 header bytes, the payload's trailing zeros cut, 2 CRC bytes)
    assert [bytes(m.get_msgbuf()[10:-2]).ljust(51, b'\0')[1:51] for m in sent] == [
        b'x' * 49 + b'y', 'Höhe 5 m'.encode() + bytes(41), b'a' * 49 + 'é'.encode()[:1]]
    assert [m.severity for m in sent] == [4, 6, 6]
    assert [r.getMessage() for r in caplog.records if 'truncating' in r.getMessage()] == [
        'Status text too long: truncating...'] * 2


def test_rc_out_and_sys_status_as_mavros():
    """~rc/out as mavros 1.21's rc_io: 16 outputs a port (MAVLink 2), every port seen so far, stamped with
    the FCU's time (ROS time now until the clock offset is known); ~sys_status: SYS_STATUS as it is."""
    from offboard_py.bridge import rc_io
    rig = Rig(rc_io.RcIo, sys_status.SysStatus)
    rig.fcu.send(BUILD.servo_output_raw_encode(5000000, 0, 1500, 1510, 1520, 1530, 900, 900, 900, 900))
    out = rig.published('~rc/out')[-1]
    assert list(out.channels) == [1500, 1510, 1520, 1530] + [900] * 4 + [0] * 8
    rig.fcu.send(BUILD.servo_output_raw_encode(5100000, 1, *[1000 + i for i in range(8)], *[2000] * 8))
    out = rig.published('~rc/out')[-1]
    assert list(out.channels) == [1500, 1510, 1520, 1530] + [900] * 4 + [0] * 8 + [1000 + i for i in range(8)] + \
        [2000] * 8, 'port 1 after port 0'
    rig.bridge.set_connected(True)
    rig.fcu.send(BUILD.servo_output_raw_encode(5200000, 1, *[1100] * 16))
    assert list(rig.published('~rc/out')[-1].channels) == [0] * 16 + [1100] * 16, 'a new connection forgets port 0'
    rig.fcu.send(BUILD.sys_status_encode(0x0300402F, 0x0301402F, 0x1320C83F, 137, 16200, -100, 100, 0, 0, 0, 0, 0, 0))
    st = rig.published('~sys_status')[-1]
    assert (st.sensors_present, st.sensors_enabled, st.sensors_health) == (0x0300402F, 0x0301402F, 0x1320C83F)
    assert (st.load, st.voltage_battery, st.current_battery, st.battery_remaining) == (137, 16200, -100, 100)


def test_attitude_setpoints_go_out_in_ned_and_targets_come_back_enu():
    from geometry_msgs.msg import PoseStamped
    from mavros_msgs.msg import AttitudeTarget, Thrust
    from offboard_py.bridge import setpoint_attitude
    rig = Rig(setpoint.Setpoint, setpoint_attitude.SetpointAttitude, setpoint_attitude__use_quaternion=True)
    north = (0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5))  # ENU yaw +90 deg: facing north
    raw = AttitudeTarget(type_mask=AttitudeTarget.IGNORE_ROLL_RATE | AttitudeTarget.IGNORE_PITCH_RATE |
                         AttitudeTarget.IGNORE_YAW_RATE, thrust=0.6)
    raw.orientation.x, raw.orientation.y, raw.orientation.z, raw.orientation.w = north
    rig.ros.subscriptions['~setpoint_raw/attitude'](raw)
    [sent] = rig.fcu.got('SET_ATTITUDE_TARGET')
    assert same_rotation((sent.q[1], sent.q[2], sent.q[3], sent.q[0]), (0.0, 0.0, 0.0, 1.0)), 'north is NED identity'
    assert sent.thrust == pytest.approx(0.6) and sent.type_mask == 7
    pose = PoseStamped()
    pose.header.stamp = rospy.Time(5)
    pose.pose.orientation.x, pose.pose.orientation.y, pose.pose.orientation.z, pose.pose.orientation.w = north
    rig.ros.subscriptions['~setpoint_attitude/attitude'](pose)
    assert len(rig.fcu.got('SET_ATTITUDE_TARGET')) == 1, 'no thrust yet: nothing sent'
    thrust = Thrust(thrust=0.7)
    thrust.header.stamp = rospy.Time(5)
    rig.ros.subscriptions['~setpoint_attitude/thrust'](thrust)
    rig.ros.subscriptions['~setpoint_attitude/attitude'](pose)
    assert rig.fcu.got('SET_ATTITUDE_TARGET')[-1].thrust == pytest.approx(0.7)
    rig.fcu.send(BUILD.attitude_target_encode(100, 7, [1.0, 0.0, 0.0, 0.0], 0.1, 0.2, 0.3, 0.5))
    target = rig.published('~setpoint_raw/target_attitude')[-1]
    o = target.orientation
    assert same_rotation((o.x, o.y, o.z, o.w), north)
    assert (target.body_rate.x, target.body_rate.y, target.body_rate.z) == pytest.approx((0.1, -0.2, -0.3))


def test_setpoint_attitude_is_cmd_vel_with_thrust_as_px4_config_sets_it():
    """px4_config.yaml's use_quaternion false: mavros takes setpoint_attitude/cmd_vel's angular velocity
    as body rates, turned by its ENU <-> NED swap (y, x, -z), the attitude ignored and identity; thrust
    outside 0..1 is not sent (-1..1 with reverse_thrust)."""
    from geometry_msgs.msg import TwistStamped
    from mavros_msgs.msg import AttitudeTarget, Thrust
    from offboard_py.bridge import setpoint_attitude
    rig = Rig(setpoint.Setpoint, setpoint_attitude.SetpointAttitude)
    assert '~setpoint_attitude/attitude' not in rig.ros.subscriptions
    cmd = TwistStamped()
    cmd.header.stamp = rospy.Time(5)
    cmd.twist.angular.x, cmd.twist.angular.y, cmd.twist.angular.z = 0.1, 0.2, 0.3
    for value in (0.6, 1.2, -0.5):
        thrust = Thrust(thrust=value)
        thrust.header.stamp = rospy.Time(5)
        rig.ros.subscriptions['~setpoint_attitude/thrust'](thrust)
        rig.ros.subscriptions['~setpoint_attitude/cmd_vel'](cmd)
    [sent] = rig.fcu.got('SET_ATTITUDE_TARGET')
    assert sent.type_mask == AttitudeTarget.IGNORE_ATTITUDE and list(sent.q) == [1.0, 0.0, 0.0, 0.0]
    assert (sent.body_roll_rate, sent.body_pitch_rate, sent.body_yaw_rate, sent.thrust) == pytest.approx(
        (0.2, 0.1, -0.3, 0.6))
    assert rig.plugin.rejected == 2, 'thrust 1.2 and -0.5 refused'
    reverse = Rig(setpoint.Setpoint, setpoint_attitude.SetpointAttitude, setpoint_attitude__reverse_thrust=True)
    reverse.ros.subscriptions['~setpoint_attitude/thrust'](thrust)
    reverse.ros.subscriptions['~setpoint_attitude/cmd_vel'](cmd)
    assert [m.thrust for m in reverse.fcu.got('SET_ATTITUDE_TARGET')] == pytest.approx([-0.5])


def test_raw_attitude_clamps_thrust_and_sends_a_zero_quaternion_as_it_is():
    """mavros 1.21 sends thrust * thrust_scaling (px4_config.yaml: 1.0) clamped to 0..1, and the
    orientation as ftf::to_eigen takes it: an all-zero quaternion goes out all zero."""
    from mavros_msgs.msg import AttitudeTarget
    rig = Rig(setpoint.Setpoint)
    for thrust in (1.5, -0.2, 0.4):
        rig.ros.subscriptions['~setpoint_raw/attitude'](AttitudeTarget(type_mask=7, thrust=thrust))
    sent = rig.fcu.got('SET_ATTITUDE_TARGET')
    assert [m.thrust for m in sent] == pytest.approx([1.0, 0.0, 0.4])
    assert list(sent[0].q) == [0.0, 0.0, 0.0, 0.0]


def test_raw_attitude_thrust_scaling_scales_and_negative_sends_no_thrust():
    from mavros_msgs.msg import AttitudeTarget
    rig = Rig(setpoint.Setpoint, setpoint_raw__thrust_scaling=0.5)
    rig.ros.subscriptions['~setpoint_raw/attitude'](AttitudeTarget(type_mask=7, thrust=0.8))
    assert [m.thrust for m in rig.fcu.got('SET_ATTITUDE_TARGET')] == pytest.approx([0.4])
    rig = Rig(setpoint.Setpoint, setpoint_raw__thrust_scaling=-1.0)
    rig.ros.subscriptions['~setpoint_raw/attitude'](AttitudeTarget(type_mask=7, thrust=0.8))
    assert rig.fcu.got('SET_ATTITUDE_TARGET') == [] and rig.plugin.rejected == 1


def test_raw_global_setpoint():
    from mavros_msgs.msg import GlobalPositionTarget
    rig = Rig(setpoint.Setpoint)
    msg = GlobalPositionTarget(coordinate_frame=GlobalPositionTarget.FRAME_GLOBAL_REL_ALT, type_mask=0xFF8,
                               latitude=47.3977419, longitude=8.5455938, altitude=20.0, yaw=0.0)
    rig.ros.subscriptions['~setpoint_raw/global'](msg)
    [sent] = rig.fcu.got('SET_POSITION_TARGET_GLOBAL_INT')
    assert (sent.lat_int, sent.lon_int, sent.alt, sent.coordinate_frame) == (473977419, 85455938, 20.0, 6)
    assert sent.yaw == pytest.approx(math.pi / 2), 'ENU yaw 0 (east) is NED yaw +90 deg'


def test_setpoint_position_global_goes_out_as_mavros_s_global_int_setpoint():
    """mavros's setpointg_cb: GLOBAL_INT, position and yaw (0x1F8), int32_t(deg * 1e7), altitude as it is,
    the yaw of the orientation turned to NED/FRD without normalising it."""
    from geographic_msgs.msg import GeoPoseStamped
    rig = Rig(setpoint.Setpoint)
    send = rig.ros.subscriptions['~setpoint_position/global']
    msg = GeoPoseStamped()
    msg.header.stamp = rospy.Time(12, 345000000)
    msg.pose.position.latitude, msg.pose.position.longitude, msg.pose.position.altitude = 47.39774199, -8.54559399, 510.5
    msg.pose.orientation.w = 1.0  # facing east
    send(msg)
    msg.pose.orientation.w = 0.0  # all zero: mavros's yaw is 0, north
    send(msg)
    east, zero = rig.fcu.got('SET_POSITION_TARGET_GLOBAL_INT')
    assert (east.coordinate_frame, east.type_mask, east.lat_int, east.lon_int, east.alt, east.time_boot_ms) == (
        mavlink.MAV_FRAME_GLOBAL_INT, 0x1F8, 473977419, -85455939, 510.5, 12345), 'truncated toward zero'
    assert (east.yaw, zero.yaw, east.yaw_rate) == (pytest.approx(math.pi / 2), 0.0, 0.0)
    assert (east.target_system, east.target_component) == (1, 1)


def test_target_global_comes_back_enu():
    rig = Rig(setpoint.Setpoint)
    rig.fcu.send(BUILD.position_target_global_int_encode(5000, mavlink.MAV_FRAME_GLOBAL_INT, 0x1F8, 473977420,
                                                         85455940, 510.5, 1.0, 2.0, 3.0, 0, 0, 0, 0.0, 0.25))
    [tgt] = rig.published('~setpoint_raw/target_global')
    assert (tgt.latitude, tgt.longitude, tgt.altitude, tgt.type_mask) == pytest.approx((47.397742, 8.545594, 510.5,
                                                                                        0x1F8))
    assert (tgt.velocity.x, tgt.velocity.y, tgt.velocity.z) == (2.0, 1.0, -3.0)
    assert (tgt.yaw, tgt.yaw_rate) == (pytest.approx(math.pi / 2), -0.25)


def test_raw_mavlink_from_and_to():
    from offboard_py.bridge import mavlink_passthrough as mp
    link_frame = wire_frame = BUILD.attitude_encode(1000, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0).pack(
        mavlink.MAVLink(None, srcSystem=1, srcComponent=1))
    msg = mp.frame_to_msg(bytes(link_frame), rospy.Time(1))
    assert (msg.magic, msg.msgid, msg.sysid, msg.len) == (0xFD, mavlink.MAVLINK_MSG_ID_ATTITUDE, 1, len(link_frame) - 12)
    assert mp.msg_to_frame(msg) == bytes(wire_frame), 'from -> to gives the frame back, byte for byte'
    msg.magic = 0x55
    with pytest.raises(ValueError, match='magic 0x55'):
        mp.msg_to_frame(msg)


def test_timers_wait_for_a_wake_up_within_their_slack_and_keep_their_rate():
    """The receive loop sleeps until a task's due time plus core.TIMER_SLACK_S (so that while the FCU
    streams, the timers run in the wake-ups its datagrams cause); a task run late stays on its
    schedule: ten runs, each up to the slack late, are ten periods."""
    rig = Rig(setpoint.Setpoint)  # a plugin without timers of its own
    assert rig.bridge.scheduler.periodic == [] and rig.bridge.scheduler.next_due_s() is None
    runs = []
    task = rig.bridge.every(0.1, runs.append)
    due_s = task[1]
    assert rig.bridge.scheduler.next_due_s() == pytest.approx(due_s + core.TIMER_SLACK_S)
    for i in range(10):
        rig.bridge.run_periodic(due_s + 0.1 * i + core.TIMER_SLACK_S * 0.9)
    assert len(runs) == 10 and task[1] == pytest.approx(due_s + 1.0), 'late runs, the same schedule'
    rig.bridge.run_periodic(due_s + 0.99)
    assert len(runs) == 10, 'not before its time'


def test_a_plugin_offers_what_it_has_through_provide_only_under_known_names():
    assert Rig(sys_status.SysStatus).bridge.commands is None, 'nothing until the command plugin is loaded'
    rig = Rig(command.Command, sys_status.SysStatus)
    assert rig.bridge.commands is rig.plugin.waiter
    with pytest.raises(ValueError, match="provide\\('link'\\): not one of clock_offset, commands"):
        rig.bridge.provide('link', object())
