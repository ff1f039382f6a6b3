"""Commands the simulated PX4 answers as PX4 main 02e73e3b6f answers them, offline, on the rig of
test_sim_px4_rules (the simulator on a manual clock, the test's UDP socket on its onboard link):

- DO_SET_MODE and SET_MODE as Commander::handle_command maps base_mode and the custom main/sub mode;
- COMPONENT_ARM_DISARM's param1 read with lroundf (Commander::handle_command);
- the commands PX4's commander handles beyond the basics (DO_SET_STANDARD_MODE, RUN_PREARM_CHECKS, DO_ORBIT,
  DO_FLIGHTTERMINATION, DO_SET_HOME, DO_CHANGE_ALTITUDE);
- PING requests echoed and commands from the autopilot's own ids dropped, as mavlink_receiver.cpp.
"""

import pytest

from offboard_py import px4_modes
from offboard_py.dialect import MAV_CMD_DO_ORBIT, mavlink

from test_sim_px4_rules import CLIENT, Rig

ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
TEMPORARILY_REJECTED = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED
CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
ARM = mavlink.MAV_CMD_COMPONENT_ARM_DISARM


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.close()


def command_long(rig, command, *params):
    params = tuple(params) + (0.0,) * (7 - len(params))
    rig.send(rig.codec.command_long_encode(rig.ap.system_id, 1, command, 0, *params))
    rig.run(0.02)


def set_mode(rig, main_mode, sub_mode=0, base_mode=CUSTOM):
    """SET_MODE; the commander's one COMMAND_ACK(DO_SET_MODE) result."""
    start = len(rig.got)
    rig.send(rig.codec.set_mode_encode(rig.ap.system_id, base_mode, px4_modes.join(main_mode, sub_mode)))
    rig.run(0.02)
    results = rig.acks(mavlink.MAV_CMD_DO_SET_MODE, start)
    assert len(results) == 1, 'one COMMAND_ACK(DO_SET_MODE) for a SET_MODE: %s' % results
    return results[0]


def custom_mode(rig):
    """HEARTBEAT.custom_mode as the next heartbeat says it."""
    start = len(rig.got)
    rig.run(1.05)
    return rig.of('HEARTBEAT', start)[-1].custom_mode


def arm(rig, param1, param2=0.0):
    start = len(rig.got)
    command_long(rig, ARM, param1, param2)
    return rig.acks(ARM, start)


@pytest.mark.parametrize('main_mode, sub_mode, expected', [
    (px4_modes.MAIN_ALTITUDE_CRUISE, 0, 0x000B0000),                # main 11: Altitude Cruise
    (px4_modes.MAIN_POSCTL, px4_modes.SUB_POSCTL_SLOW, 0x02030000),  # Position Slow keeps its sub mode
    (px4_modes.MAIN_POSCTL, px4_modes.SUB_POSCTL_ORBIT, 0x00030000),  # any other POSCTL sub mode: POSCTL
    (px4_modes.MAIN_AUTO, px4_modes.SUB_FOLLOW_TARGET, 0x08040000),
    (px4_modes.MAIN_AUTO, px4_modes.SUB_PRECLAND, 0x09040000),
    (px4_modes.MAIN_AUTO, 0, 0x04040000),                           # AUTO alone: the mission
])
def test_set_mode_takes_every_mode_px4_maps_while_disarmed(rig, main_mode, sub_mode, expected):
    """Commander::handle_command (DO_SET_MODE) maps these to a navigation state and
    UserModeIntention::change allows any while disarmed; HEARTBEAT carries get_px4_custom_mode's value."""
    assert set_mode(rig, main_mode, sub_mode) == ACCEPTED
    assert custom_mode(rig) == expected


@pytest.mark.parametrize('main_mode, sub_mode', [
    (px4_modes.MAIN_RATTITUDE, 0),             # PX4_CUSTOM_MAIN_MODE_RATTITUDE_LEGACY: no longer a mode
    (9, 0),                                    # SIMPLE: reserved
    (px4_modes.MAIN_TERMINATION, 0),           # only DO_FLIGHTTERMINATION terminates
    (12, 0),
    (px4_modes.MAIN_AUTO, px4_modes.SUB_READY),
    (px4_modes.MAIN_AUTO, px4_modes.SUB_RTGS),
    (px4_modes.MAIN_AUTO, px4_modes.SUB_VTOL_TAKEOFF),  # a multicopter
])
def test_set_mode_refuses_what_px4_has_no_mode_for(rig, main_mode, sub_mode):
    """'Unsupported main mode' / 'Unsupported auto mode': TRANSITION_DENIED, TEMPORARILY_REJECTED."""
    before = custom_mode(rig)
    assert set_mode(rig, main_mode, sub_mode) == TEMPORARILY_REJECTED
    assert custom_mode(rig) == before == px4_modes.encode('AUTO.LOITER')


def test_do_set_mode_casts_its_float_fields_to_bytes(rig):
    """COMMAND_LONG DO_SET_MODE: (uint8_t)param1..3, so 3.9 is POSCTL and sub mode 2.7 Position Slow;
    the MAVLink module's own ACCEPTED comes first, then the commander's."""
    start = len(rig.got)
    command_long(rig, mavlink.MAV_CMD_DO_SET_MODE, CUSTOM + 0.5, 3.9, 2.7)
    assert rig.acks(mavlink.MAV_CMD_DO_SET_MODE, start) == [ACCEPTED, ACCEPTED]
    assert custom_mode(rig) == 0x02030000


def test_follow_target_and_precland_are_taken_but_prevent_arming(rig):
    """Both prevent arming (mode_requirements.cpp: mode_req_prevent_arming), as AUTO.LAND does."""
    for sub_mode in (px4_modes.SUB_FOLLOW_TARGET, px4_modes.SUB_PRECLAND):
        assert set_mode(rig, px4_modes.MAIN_AUTO, sub_mode) == ACCEPTED
        assert arm(rig, 1.0) == [TEMPORARILY_REJECTED]
        assert not rig.ap.status().armed
@pytest.mark.parametrize('param1, armed', [(0.6, True), (0.5, True), (1.4, True), (1.0, True),
                                           (0.4, False), (-0.4, False)])
def test_arm_disarm_reads_param1_rounded(rig, param1, armed):
    """const int8_t arming_action = lroundf(param1): 0.5 and 0.6 arm, 0.4 and -0.4 are a disarm
    (ACCEPTED: already disarmed)."""
    assert arm(rig, param1) == [ACCEPTED]
    assert rig.ap.status().armed == armed


@pytest.mark.parametrize('param1', [2.0, 1.5, -1.0, -0.6])
def test_arm_disarm_with_another_action_is_unsupported(rig, param1):
    """lroundf(param1) neither 0 nor 1: 'Unsupported ARM_DISARM param', and the result stays UNSUPPORTED."""
    assert arm(rig, param1) == [UNSUPPORTED]
    assert not rig.ap.status().armed


def test_arm_disarm_nan_is_a_disarm_as_on_x86_64(rig):
    """lroundf(NaN) is LONG_MIN on PX4 SITL's x86-64, and its int8_t cast 0: a disarm, not a refusal."""
    assert arm(rig, 1.0) == [ACCEPTED]
    assert arm(rig, float('nan')) == [ACCEPTED]
    assert not rig.ap.status().armed


def command_result(rig, command, *params):
    start = len(rig.got)
    command_long(rig, command, *params)
    results = rig.acks(command, start)
    assert len(results) == 1, 'one COMMAND_ACK(%d): %s' % (command, results)
    return results[0]


@pytest.mark.parametrize('standard, expected', [(1, 'POSCTL'), (2, 'POSCTL.ORBIT'), (4, 'ALTCTL'), (5, 'AUTO.RTL'),
                                                (6, 'AUTO.MISSION'), (7, 'AUTO.LAND'), (8, 'AUTO.TAKEOFF')])
def test_set_standard_mode_selects_the_mode_px4_maps_it_to(rig, standard, expected):
    """DO_SET_STANDARD_MODE: getNavStateFromStandardMode (standard_modes.hpp) for a multicopter, then the
    mode change (any while disarmed); the simulator lists these standard modes in AVAILABLE_MODES."""
    assert command_result(rig, mavlink.MAV_CMD_DO_SET_STANDARD_MODE, standard + 0.3) == ACCEPTED
    assert custom_mode(rig) == px4_modes.encode(expected)


@pytest.mark.parametrize('standard', [0, 3, 9, float('nan')])
def test_set_standard_mode_without_a_multicopter_mode_fails(rig, standard):
    """NON_STANDARD, CRUISE (fixed wing only) and unknown numbers: NAVIGATION_STATE_MAX, FAILED."""
    assert command_result(rig, mavlink.MAV_CMD_DO_SET_STANDARD_MODE, standard) == mavlink.MAV_RESULT_FAILED


def test_run_prearm_checks_is_accepted(rig):
    assert command_result(rig, mavlink.MAV_CMD_RUN_PREARM_CHECKS) == ACCEPTED


def test_orbit_selects_the_orbit_mode(rig):
    """DO_ORBIT on a multicopter: NAVIGATION_STATE_ORBIT, custom_mode POSCTL sub mode ORBIT (0x01030000)."""
    assert command_result(rig, MAV_CMD_DO_ORBIT, 10.0) == ACCEPTED
    assert custom_mode(rig) == 0x01030000


def test_flight_termination_denied_disarmed_then_terminates_armed_for_good(rig):
    """DENIED with param1 <= 0.5 or disarmed; armed, TERMINATION (0x000A0000), motors off, and no mode
    change out of it (UserModeIntention::change)."""
    assert command_result(rig, mavlink.MAV_CMD_DO_FLIGHTTERMINATION, 1.0) == mavlink.MAV_RESULT_DENIED
    assert arm(rig, 1.0) == [ACCEPTED]
    assert command_result(rig, mavlink.MAV_CMD_DO_FLIGHTTERMINATION, 0.5) == mavlink.MAV_RESULT_DENIED
    assert command_result(rig, mavlink.MAV_CMD_DO_FLIGHTTERMINATION, 1.0) == ACCEPTED
    assert custom_mode(rig) == 0x000A0000
    assert not rig.ap.flight.vehicle.motors_on
    assert set_mode(rig, px4_modes.MAIN_AUTO, px4_modes.SUB_LOITER) == TEMPORARILY_REJECTED


def test_set_home_here_or_at_a_given_position(rig):
    """DO_SET_HOME (COM_HOME_EN 1): param1 1 the current position; param1 0 the latitude, longitude
    and altitude given, DENIED unless all three are finite."""
    lat0, lon0, alt0 = rig.ap.origin.lat0, rig.ap.origin.lon0, rig.ap.origin.alt0
    assert command_result(rig, mavlink.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat0, lon0, float('nan')) == \
        mavlink.MAV_RESULT_DENIED
    assert command_result(rig, mavlink.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat0 + 1e-4, lon0, alt0 + 10) == ACCEPTED
    north, east, down = rig.ap.flight.home
    assert north == pytest.approx(11.1, abs=0.1) and east == pytest.approx(0, abs=0.1) and down == pytest.approx(-10)
    assert command_result(rig, mavlink.MAV_CMD_DO_SET_HOME, 1) == ACCEPTED
    assert rig.ap.flight.home[0] == pytest.approx(0.0, abs=1.0)


def test_change_altitude_loiters_and_climbs_to_it_when_armed(rig):
    """DO_CHANGE_ALTITUDE: AUTO.LOITER (Commander::handle_command) and, armed, a reposition to param1
    AMSL above where the vehicle is (navigator_main.cpp)."""
    assert arm(rig, 1.0) == [ACCEPTED]
    target_amsl = rig.ap.origin.alt0 + 5.0
    assert command_result(rig, mavlink.MAV_CMD_DO_CHANGE_ALTITUDE, target_amsl) == ACCEPTED
    rig.run(8.0)
    st = rig.ap.status()
    assert st.nav_mode == 'AUTO.LOITER' and st.armed
    assert -rig.ap.flight.vehicle.position[2] == pytest.approx(5.0, abs=0.5), rig.ap.flight.vehicle.position


def test_ping_request_is_echoed_to_its_sender(rig):
    """MavlinkReceiver::handle_message_ping: target 0/0 is a request, sent back with the sender as target;
    a PING with a target is someone's answer and gets none."""
    rig.send(rig.codec.ping_encode(123456, 7, 0, 0))
    rig.send(rig.codec.ping_encode(654321, 8, 42, 1))
    rig.run(0.02)
    # the PING stream's own requests (target 0/0) aside
    pings = [(m.time_usec, m.seq, m.target_system, m.target_component) for m in rig.of('PING') if m.target_system]
    assert pings == [(123456, 7) + CLIENT], pings


def test_command_from_the_autopilots_own_ids_is_ignored_unless_the_receiver_handles_it(rig):
    """handle_message_command_both: a command for the commander from the autopilot's own system and
    component is dropped without an ACK; REQUEST_MESSAGE and DO_SET_MODE are handled before that check."""
    def send_as(component, msg):
        codec = mavlink.MAVLink(None, srcSystem=rig.ap.system_id, srcComponent=component)
        rig.ap.link.handle_datagram(bytes(msg.pack(codec)), rig.sock.getsockname())

    start = len(rig.got)
    send_as(1, rig.codec.command_long_encode(rig.ap.system_id, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0))
    send_as(1, rig.codec.command_long_encode(rig.ap.system_id, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                             mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0))
    rig.run(0.02)
    assert rig.acks(ARM, start) == [] and not rig.ap.status().armed, 'the spoofed arm is ignored'
    assert rig.acks(mavlink.MAV_CMD_REQUEST_MESSAGE, start) == [ACCEPTED]
    send_as(mavlink.MAV_COMP_ID_ONBOARD_COMPUTER, rig.codec.command_long_encode(rig.ap.system_id, 1, ARM, 0, 1, 0, 0,
                                                                                0, 0, 0, 0))
    rig.run(0.02)
    assert rig.acks(ARM, start) == [ACCEPTED], 'the same system, another component: taken'


def message_interval(rig, *params, command=mavlink.MAV_CMD_SET_MESSAGE_INTERVAL):
    start = len(rig.got)
    command_long(rig, command, *params)
    return rig.acks(command, start), rig.of('MESSAGE_INTERVAL', start)


def test_set_message_interval_reads_its_parameters_as_px4s_receiver(rig):
    """MavlinkReceiver::set_message_interval: the id is (int)(param1 + 0.5) (30.6 is ATTITUDE's 31,
    ATTITUDE_QUATERNION); param3, param4 and param7 must round to 0 (FAILED otherwise); NaN asks for the
    default rate, as 0 does."""
    attitude, quaternion = mavlink.MAVLINK_MSG_ID_ATTITUDE, mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION
    assert message_interval(rig, attitude, 100000, 0.4, -0.4)[0] == [ACCEPTED], 'params 3 and 4 round to 0'
    for params in ((attitude, 100000, 1), (attitude, 100000, 0, 1), (attitude, 100000, 0, 0, 0, 0, 1)):
        assert message_interval(rig, *params)[0] == [mavlink.MAV_RESULT_FAILED], params
    assert message_interval(rig, quaternion - 0.4, 250000)[0] == [ACCEPTED]
    _, answer = message_interval(rig, quaternion, command=mavlink.MAV_CMD_GET_MESSAGE_INTERVAL)
    assert (answer[0].message_id, answer[0].interval_us) == (quaternion, 250000)
    assert message_interval(rig, quaternion, float('nan'))[0] == [ACCEPTED]
    _, answer = message_interval(rig, quaternion, command=mavlink.MAV_CMD_GET_MESSAGE_INTERVAL)
    assert answer[0].interval_us == rig.ap.streams[rig.ap.links[0]].interval_us(quaternion) != 250000, \
        'NaN: back to the default'


def test_get_message_interval_of_a_stream_not_running_is_minus_one(rig):
    """MavlinkReceiver::get_message_interval: -1 when no stream of that id runs on the link (PX4's
    answer for an id it does not know too), with ACCEPTED."""
    for msg_id in (9999, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION):
        acks, answer = message_interval(rig, msg_id, command=mavlink.MAV_CMD_GET_MESSAGE_INTERVAL)
        assert acks == [ACCEPTED] and (answer[0].message_id, answer[0].interval_us) == (msg_id, -1)
