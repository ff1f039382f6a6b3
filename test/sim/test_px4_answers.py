"""The simulated PX4's answers held to real PX4 SITL's, over UDP (reference/px4-sitl-measured.md,
"Turn 3 recordings", sections 3, 4 and 6): AVAILABLE_MODES and CURRENT_MODE, the ACKs of a mode
change, PROTOCOL_VERSION and its ACK, LINK_NODE_STATUS.messages_lost, and what HEARTBEAT and
SYS_STATUS say around a disarm. Seconds are simulated ones (the client's clock, conftest).
"""

import json
import os

from offboard_py.dialect import mavlink
from offboard_py.testing import measured_tables
from offboard_py.testing.sim_client import ACCEPTED, DENIED, TEMPORARILY_REJECTED

FAST = ('--ready-delay', '1')
CENSUS_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'reference',
                           'px4-sitl-gcs-census.json')
MEASURED = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'reference', 'px4-sitl-measured.md')
PREARM, LOGGING = mavlink.MAV_SYS_STATUS_PREARM_CHECK, mavlink.MAV_SYS_STATUS_LOGGING
# section 4: two COMMAND_ACK(176) 1-8 ms apart; PROTOCOL_VERSION's ACK about 4 ms after it. Those milliseconds
# are held in simulated time offline (test/unit/test_sim_answer_timing.py): over UDP they are the scheduler's
# (a busy machine read 48 ms), so here only the order and the count are asserted
LIBRARY_HASH = bytes.fromhex('6521d1aee97ea451')  # PROTOCOL_VERSION.library_version_hash, wire order
# section 6: the logger's bit left 2.2 s after a disarm 0.93 s after the arm (a log of its own)
DISARM_AFTER_ARM_S, LOGGER_GONE_S = 0.93, 2.2
TOLERANCE = 0.10
with open(CENSUS_FILE) as _f:
    CENSUS = json.load(_f)


def recorded_available_modes():
    """{mode_index: (custom_mode, standard_mode, properties, mode_name)} from the recording's table (section 3)."""
    return {index: (custom, standard, properties, name)
            for index, custom, _, standard, properties, name in measured_tables.available_modes(MEASURED)}


def since(client, start, *types):
    with client.lock:
        return [(t, m) for t, m in client.history[start:] if m.get_type() in types]


def wait_standby(client, timeout_s=10.0):
    client.wait_for(lambda: client.latest.get('HEARTBEAT') and
                    client.latest['HEARTBEAT'].system_status == mavlink.MAV_STATE_STANDBY, timeout_s, 'STANDBY')


def request_available_modes(client, which):
    """(AVAILABLE_MODES received, the ACK's result), both in arrival order, checking the ACK comes last."""
    start = len(client.history)
    result = client.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AVAILABLE_MODES, which)[0]
    client.sleep(0.2)
    got = since(client, start, 'AVAILABLE_MODES', 'COMMAND_ACK')
    ack_at = next(i for i, (_, m) in enumerate(got)
                  if m.get_type() == 'COMMAND_ACK' and m.command == mavlink.MAV_CMD_REQUEST_MESSAGE)
    modes = [m for _, m in got if m.get_type() == 'AVAILABLE_MODES']
    assert all(m.get_type() != 'AVAILABLE_MODES' for _, m in got[ack_at:]), 'AVAILABLE_MODES after the ACK'
    return modes, result


def test_available_modes_and_current_mode_as_px4_sitl(start_sim):
    _, client = start_sim(*FAST)
    wait_standby(client)
    recorded = recorded_available_modes()
    modes, result = request_available_modes(client, 0)
    assert result == ACCEPTED
    assert [m.mode_index for m in modes] == list(range(1, 27)) and {m.number_modes for m in modes} == {26}
    for m in modes:
        assert (m.custom_mode, m.standard_mode, m.properties, m.mode_name) == recorded[m.mode_index], m
    for which in (1, 2):
        modes, result = request_available_modes(client, which)
        assert result == ACCEPTED and [(m.mode_index, m.custom_mode) for m in modes] == [(which, recorded[which][0])]
    # PX4's stream refuses an index past its modes (MavlinkStreamAvailableModes::request_message)
    modes, result = request_available_modes(client, 27)
    assert (modes, result) == ([], DENIED)

    # CURRENT_MODE at PX4's rate (the GCS link's census): AUTO.LOITER on the ground, then OFFBOARD. The rate is
    # read from the spacing of the messages (a count in a window counts one more when a datagram is late
    # on a loaded machine)
    rate_hz = CENSUS['rates_hz']['CURRENT_MODE']
    start = len(client.history)
    client.sleep(3.5 / rate_hz)
    stamped = since(client, start, 'CURRENT_MODE')
    gaps = sorted(b[0] - a[0] for a, b in zip(stamped, stamped[1:]))
    assert len(stamped) >= 3, '%d CURRENT_MODE in %.1f s (PX4: %g Hz)' % (len(stamped), 3.5 / rate_hz, rate_hz)
    assert abs(gaps[len(gaps) // 2] * rate_hz - 1.0) < 0.15, \
        'CURRENT_MODE %.2f s apart (median of %s), PX4 %g Hz' % (gaps[len(gaps) // 2], gaps, rate_hz)
    current = [m for _, m in stamped]
    assert {(m.standard_mode, m.custom_mode, m.intended_custom_mode) for m in current} == {(0, 0x03040000, 0x03040000)}
    client.start_stream(down=0.0)
    client.sleep(0.3)
    assert client.set_mode('OFFBOARD') == ACCEPTED
    start = len(client.history)
    client.sleep(2.5)
    current = [m for _, m in since(client, start, 'CURRENT_MODE')]
    assert current and {(m.standard_mode, m.custom_mode, m.intended_custom_mode) for m in current} == \
        {(0, 0x00060000, 0x00060000)}


def test_do_set_mode_gets_two_acks_and_set_mode_one(start_sim):
    _, client = start_sim(*FAST)
    wait_standby(client)
    for _ in range(5):
        start = len(client.acks)
        assert client.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3,
                              acks=2) == [ACCEPTED, ACCEPTED]
        client.sleep(0.3)
        acks = [(t, a) for t, a in client.acks[start:] if a.command == mavlink.MAV_CMD_DO_SET_MODE]
        assert len(acks) == 2, '%d COMMAND_ACK(176) for one DO_SET_MODE (PX4: 2)' % len(acks)
        assert acks[0][0] <= acks[1][0], 'the two ACKs in the order they came'
    start = len(client.acks)
    assert client.set_mode('AUTO.LOITER') == ACCEPTED
    client.sleep(0.5)
    assert len([a for _, a in client.acks[start:] if a.command == mavlink.MAV_CMD_DO_SET_MODE]) == 1, \
        'the SET_MODE message gets one COMMAND_ACK(176)'


def test_protocol_version_then_its_ack(start_sim):
    _, client = start_sim(*FAST)
    wait_standby(client)
    for command, param1 in ((mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION, 1),
                            (mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION, 0),  # param1 is not checked
                            (mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_PROTOCOL_VERSION)):
        start = len(client.history)
        assert client.command(command, param1)[0] == ACCEPTED
        client.sleep(0.1)
        got = [(t, m) for t, m in since(client, start, 'PROTOCOL_VERSION', 'COMMAND_ACK')
               if m.get_type() == 'PROTOCOL_VERSION' or m.command == command]
        assert [m.get_type() for _, m in got] == ['PROTOCOL_VERSION', 'COMMAND_ACK'], (command, param1)
        (t_version, version), (t_ack, ack) = got
        assert (version.version, version.min_version, version.max_version) == (200, 100, 203)
        assert bytes(version.spec_version_hash) == bytes(8) and bytes(version.library_version_hash) == LIBRARY_HASH
        assert (ack.result, ack.progress, ack.result_param2) == (ACCEPTED, 0, 0)
        assert t_version <= t_ack, 'the ACK after PROTOCOL_VERSION'


def test_messages_lost_counts_sequence_gaps_as_px4(start_sim):
    """A sender that always sends seq 0 makes PX4 count 254 lost per message after its first (run 1 of
    the recording: 2286 after ten); the client's own messages advance their sequence and lose none."""
    _, client = start_sim(*FAST)
    wait_standby(client)
    stuck = mavlink.MAVLink(None, srcSystem=200, srcComponent=191)  # pack() without send(): seq stays 0
    heartbeat = stuck.heartbeat_encode(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    client.sleep(1.2)
    before = client.latest['LINK_NODE_STATUS'].messages_lost
    for _ in range(10):
        with client.lock:
            client.write(heartbeat.pack(stuck))
        client.sleep(0.05)
    client.sleep(1.2)
    lost = client.latest['LINK_NODE_STATUS'].messages_lost - before
    assert lost == 254 * 9, 'messages_lost +%d for ten seq-0 messages (PX4: %d)' % (lost, 254 * 9)
    for _ in range(10):
        client.send(client.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0))
    client.sleep(1.2)
    assert client.latest['LINK_NODE_STATUS'].messages_lost - before == 254 * 9, 'an advancing sender loses none'


def bit_change_s(client, start, bit, t0, present):
    """(last SYS_STATUS time with `bit` as before, first without) after t0, in seconds from t0."""
    field = 'onboard_control_sensors_present' if present else 'onboard_control_sensors_health'
    statuses = [(t, getattr(m, field) & bit) for t, m in since(client, start, 'SYS_STATUS') if t >= t0]
    first = statuses[0][1]
    change = next(i for i, (_, v) in enumerate(statuses) if v != first)
    return statuses[change - 1][0] - t0, statuses[change][0] - t0


def test_after_a_disarm_standby_at_once_and_the_logger_bit_goes_later(start_sim):
    _, client = start_sim(*FAST)
    wait_standby(client)
    # a first flight ends the boot log; the next arming starts a log of its own (SDLOG_MODE 1)
    assert client.arm() == ACCEPTED
    client.sleep(1.0)
    assert client.arm(False) == ACCEPTED
    client.wait_for(lambda: not client.latest['SYS_STATUS'].onboard_control_sensors_present & LOGGING, 6.0,
                    'the boot log closed')
    start = len(client.history)
    asked_s = client.now()
    assert client.arm() == ACCEPTED
    # "after arming": from the arm's ACK as it arrived (PX4 ACKed within 8-12 ms of a command, section 6), so a
    # command that waited for the simulator's turn on a busy machine does not move the bit's time
    armed_s = next(t for t, m in since(client, start, 'COMMAND_ACK')
                   if m.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM)
    client.sleep(DISARM_AFTER_ARM_S - (client.now() - asked_s))
    disarm_s = client.now()
    assert client.arm(False) == ACCEPTED
    client.sleep(LOGGER_GONE_S * 1.5)
    last_without, first_with = bit_change_s(client, start, LOGGING, armed_s, present=True)
    print('logger bit back between %.2f and %.2f s after arming (PX4 about 0.3 s)' % (last_without, first_with))
    assert last_without <= 0.3 * (1 + TOLERANCE) and first_with >= 0.3 * (1 - TOLERANCE)
    last_with, first_without = bit_change_s(client, start, LOGGING, disarm_s, present=True)
    print('logger bit gone between %.2f and %.2f s after the disarm (PX4 %.1f s)' % (last_with, first_without,
                                                                                   LOGGER_GONE_S))
    assert last_with <= LOGGER_GONE_S * (1 + TOLERANCE) and first_without >= LOGGER_GONE_S * (1 - TOLERANCE)
    after = [(t, m) for t, m in client.history[start:] if t > disarm_s + 0.05]
    assert {m.system_status for _, m in after if m.get_type() == 'HEARTBEAT'} == {mavlink.MAV_STATE_STANDBY}
    assert all(m.onboard_control_sensors_health & PREARM and m.onboard_control_sensors_health & LOGGING
               for _, m in after if m.get_type() == 'SYS_STATUS'), 'health keeps PREARM_CHECK and LOGGING'


def test_offboard_without_setpoints_fails_the_prearm_checks_until_they_resume(start_sim):
    """Section 6: OFFBOARD selected, setpoints stopped: bit 28 and STANDBY go about 1.0 s (COM_OF_LOSS_T)
    after the last setpoint; when the setpoints resume, bit 28 is back within 0.12 s (PX4's SYS_STATUS
    comes at 5 Hz, so within its next one) and STANDBY at the next HEARTBEAT."""
    _, client = start_sim(*FAST)
    wait_standby(client)
    client.start_stream(down=0.0)
    client.sleep(0.5)
    assert client.set_mode('OFFBOARD') == ACCEPTED
    client.sleep(0.5)
    start = len(client.history)
    client.stop_stream()
    last_setpoint_s = client.last_setpoint_s
    client.sleep(2.5)
    last_with, first_without = bit_change_s(client, start, PREARM, last_setpoint_s, present=False)
    assert last_with <= 1.0 * (1 + TOLERANCE) and first_without >= 1.0 * (1 - TOLERANCE), (last_with, first_without)
    assert client.latest['HEARTBEAT'].system_status == mavlink.MAV_STATE_UNINIT
    start = len(client.history)
    resumed_s = client.now()
    client.start_stream(down=0.0)
    client.sleep(1.2)
    back = next(t for t, m in since(client, start, 'SYS_STATUS')
                if t >= resumed_s and m.onboard_control_sensors_health & PREARM) - resumed_s
    assert back <= 0.12 + 0.2, 'PREARM_CHECK back %.2f s after the setpoints resumed' % back
    heartbeats = [m for t, m in since(client, start, 'HEARTBEAT') if t > resumed_s + 0.05]
    assert heartbeats and heartbeats[0].system_status == mavlink.MAV_STATE_STANDBY


def test_a_disarm_while_the_takeoff_climbs_is_temporarily_rejected(start_sim):
    """Section 6: OFFBOARD, setpoint z = -2: a disarm 0.93 s after the arm is accepted; once the takeoff has
    lifted the land detector's maybe-landed (PX4: by 1.9 s; this vehicle model: 2.05 s) it is
    TEMPORARILY_REJECTED and the vehicle stays armed and climbs."""
    _, client = start_sim(*FAST)
    wait_standby(client)
    client.start_stream(down=-2.0)
    client.sleep(0.5)
    assert client.set_mode('OFFBOARD') == ACCEPTED
    armed_s = client.now()
    assert client.arm() == ACCEPTED
    client.sleep(DISARM_AFTER_ARM_S - (client.now() - armed_s))
    assert client.arm(False) == ACCEPTED
    client.wait_armed(False, 1.0)
    armed_s = client.now()
    assert client.arm() == ACCEPTED
    client.sleep(2.5 - (client.now() - armed_s))
    z = client.z()
    assert client.arm(False) == TEMPORARILY_REJECTED
    client.sleep(3.0)
    assert client.armed() and client.z() < z - 0.5, 'it stayed armed and climbed: %s' % client.describe()
