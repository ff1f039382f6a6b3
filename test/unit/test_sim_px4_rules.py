"""What the simulated PX4 answers and sends on its own, held to PX4 main 02e73e3b6f and its recordings,
offline: the simulator on a clock that moves only when the test moves it, its onboard link sending to a
UDP socket of the test's on loopback, requests handed to the link as datagrams (MavlinkLink.handle_datagram).

- COMMAND_INT and COMMAND_LONG sentinels and frames as mavlink_receiver.cpp refuses them;
- SET_MODE for all systems (target 0), as the commander takes a command for system 0;
- GPS_GLOBAL_ORIGIN once, 1.0 s after the links start (reference/conversations/takeoff-*-px4), and on request;
- STATUSTEXT only while a MAV_TYPE_GCS HEARTBEAT is heard on the link (PX4's STATUSTEXT stream);
- the PARAM_VALUEs PX4 sends unasked at boot (reference/px4-sitl-boot-params.json).
"""

import json
import os
import socket
import struct

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim import autopilot as ap_module
from offboard_py.sim.autopilot import SimulatedPx4
from offboard_py.testing.reference import px4_figure

from manual_clock import ManualClock

STEP_S = 0.01
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BOOT_PARAMS = os.path.join(REPO, 'reference', 'px4-sitl-boot-params.json')
CLIENT = (255, mavlink.MAV_COMP_ID_MISSIONPLANNER)


class Rig:
    """The simulator, its clock and the test's end of the onboard link."""

    def __init__(self, ready_delay_s=0.0):
        self.clock = ManualClock(1000.0)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(('127.0.0.1', 0))
        self.sock.setblocking(False)
        self.ap = SimulatedPx4(local_port=0, remote_port=self.sock.getsockname()[1], gcs=False,
                               ready_delay_s=ready_delay_s, clock=self.clock)
        self.codec = mavlink.MAVLink(None, srcSystem=CLIENT[0], srcComponent=CLIENT[1])
        self.reader = mavlink.MAVLink(None)
        self.got = []  # (boot s, message) in arrival order

    def send(self, msg):
        self.ap.link.handle_datagram(bytes(msg.pack(self.codec)), self.sock.getsockname())

    def run(self, seconds):
        """Step the simulator for `seconds` of its clock, reading what it sent after each step."""
        for _ in range(int(round(seconds / STEP_S))):
            self.clock.now_s += STEP_S
            self.ap.step(STEP_S)
            self.read()

    def read(self):
        while True:
            try:
                data = self.sock.recv(65536)
            except BlockingIOError:
                return
            for msg in self.reader.parse_buffer(data) or []:
                self.got.append((self.ap.t(), msg))

    def of(self, kind, since=0):
        return [m for _, m in self.got[since:] if m.get_type() == kind]

    def acks(self, command, since=0):
        return [m.result for m in self.of('COMMAND_ACK', since) if m.command == command]

    def close(self):
        self.ap.close_links()
        self.sock.close()


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.close()


def command_int(rig, command, frame, x=0, y=0, z=0.0, target=None, params=(0.0, 0.0, 0.0, 0.0)):
    target = rig.ap.system_id if target is None else target
    return rig.codec.command_int_encode(target, 1, frame, command, 0, 0, *params, x, y, z)


def test_command_int_in_any_frame_but_global_int_is_unsupported_mav_frame(rig):
    """mavlink_receiver.cpp handle_message_command_int: "PX4 only supports global frame" - not even
    GLOBAL_RELATIVE_ALT_INT; checked before the target, so a command for another system gets it too."""
    for frame in (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_FRAME_GLOBAL):
        start = len(rig.got)
        rig.send(command_int(rig, mavlink.MAV_CMD_REQUEST_MESSAGE, frame, params=(
            mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0.0, 0.0, 0.0)))
        rig.run(0.02)
        assert rig.acks(mavlink.MAV_CMD_REQUEST_MESSAGE, start) == [mavlink.MAV_RESULT_UNSUPPORTED_MAV_FRAME], frame
        assert not rig.of('AUTOPILOT_VERSION', start), 'nothing is sent for a refused frame'
    start = len(rig.got)
    rig.send(command_int(rig, mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_FRAME_LOCAL_NED, target=99))
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_NAV_LAND, start) == [mavlink.MAV_RESULT_UNSUPPORTED_MAV_FRAME]
    start = len(rig.got)
    rig.send(command_int(rig, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAV_FRAME_GLOBAL_INT, params=(
        mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0.0, 0.0, 0.0)))
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_REQUEST_MESSAGE, start) == [mavlink.MAV_RESULT_ACCEPTED]
    assert len(rig.of('AUTOPILOT_VERSION', start)) == 1


def test_nan_sent_as_int_in_command_int_and_int32_max_as_float_in_command_long_are_denied(rig):
    """x and y both 0x7ff80000 (NaN's float bits) in COMMAND_INT, param5 and param6 both INT32_MAX in
    COMMAND_LONG: PX4 answers DENIED whatever the command, before it looks at the frame or target."""
    start = len(rig.got)
    rig.send(command_int(rig, mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_FRAME_LOCAL_NED, x=0x7FF80000, y=0x7FF80000))
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_NAV_LAND, start) == [mavlink.MAV_RESULT_DENIED]
    start = len(rig.got)
    rig.send(rig.codec.command_long_encode(rig.ap.system_id, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                           mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0,
                                           2147483647.0, 2147483647.0, 0))
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_REQUEST_MESSAGE, start) == [mavlink.MAV_RESULT_DENIED]
    assert not rig.of('AUTOPILOT_VERSION', start)
    start = len(rig.got)  # one of the two alone is a value, not the sentinel
    rig.send(rig.codec.command_long_encode(rig.ap.system_id, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                           mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 2147483647.0, 0, 0))
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_REQUEST_MESSAGE, start) == [mavlink.MAV_RESULT_ACCEPTED]


def test_set_mode_for_all_systems_is_taken_and_for_another_ignored(rig):
    """The receiver makes SET_MODE a DO_SET_MODE vehicle command for its target_system; the commander
    takes target 0 (all) as its own and ignores another system's."""
    hold = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    start = len(rig.got)
    rig.send(rig.codec.set_mode_encode(0, hold, (3 << 24) | (4 << 16)))  # AUTO.LOITER
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_DO_SET_MODE, start) == [mavlink.MAV_RESULT_ACCEPTED]
    start = len(rig.got)
    rig.send(rig.codec.set_mode_encode(99, hold, (3 << 24) | (5 << 16)))
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_DO_SET_MODE, start) == [], 'SET_MODE for system 99 is not ours'


def recorded_first_origin_s():
    """When real PX4 first sent GPS_GLOBAL_ORIGIN in each recorded conversation (reference/conversations/
    takeoff-*-px4): seconds after the link's first message."""
    import lzma
    times = []
    for name in ('takeoff-mavros-px4', 'takeoff-bridge-px4'):
        with lzma.open(os.path.join(REPO, 'reference', 'conversations', name + '.compact.jsonl.xz'), 'rt') as f:
            times.append(next(msg['t'] for msg in map(json.loads, f) if msg['type'] == 'GPS_GLOBAL_ORIGIN'))
    return times


def test_gps_global_origin_once_a_second_after_start_and_on_request(rig):
    """Both real-PX4 recordings: one GPS_GLOBAL_ORIGIN about 1.0 s after the link's first message, the
    estimator's origin, time_usec when it was set (0.636/0.644 s); none again through the flight.
    REQUEST_MESSAGE 49 sends it with ACCEPTED (PX4's stream request_message), DENIED before there is one."""
    start = len(rig.got)
    rig.send(rig.codec.command_long_encode(rig.ap.system_id, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                           mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, 0, 0, 0, 0, 0, 0))
    rig.run(0.02)
    assert rig.acks(mavlink.MAV_CMD_REQUEST_MESSAGE, start) == [mavlink.MAV_RESULT_DENIED], 'no origin at boot'
    rig.run(3.0)
    sent = [(t, m) for t, m in rig.got if m.get_type() == 'GPS_GLOBAL_ORIGIN']
    assert len(sent) == 1, 'once: %s' % sent
    t, origin = sent[0]
    assert min(recorded_first_origin_s()) - 0.05 <= t <= max(recorded_first_origin_s()) + 0.05, t
    lat, lon, alt = ap_module.DEFAULT_HOME
    assert (origin.latitude, origin.longitude, origin.altitude, origin.time_usec) == (
        round(lat * 1e7), round(lon * 1e7), round(alt * 1000), 640000)
    start = len(rig.got)
    rig.send(rig.codec.command_long_encode(rig.ap.system_id, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                           mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, 0, 0, 0, 0, 0, 0))
    rig.run(0.02)
    assert len(rig.of('GPS_GLOBAL_ORIGIN', start)) == 1
    assert rig.acks(mavlink.MAV_CMD_REQUEST_MESSAGE, start) == [mavlink.MAV_RESULT_ACCEPTED]


def refused_param(rig, value=500.0):
    """PARAM_SET of RTL_RETURN_ALT outside its range: the simulator refuses it and says so in a text."""
    rig.send(rig.codec.param_set_encode(rig.ap.system_id, 1, b'RTL_RETURN_ALT', value, mavlink.MAV_PARAM_TYPE_REAL32))


def refusal(value):
    return 'RTL_RETURN_ALT=%r is outside [0, 150]' % value


def heartbeat(rig, mav_type):
    rig.send(rig.codec.heartbeat_encode(mav_type, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE))


def test_statustext_only_while_a_ground_station_is_heard_on_the_link(rig):
    """PX4's STATUSTEXT stream sends while is_gcs_connected(): a MAV_TYPE_GCS HEARTBEAT within 2.5 s.
    mavros's heartbeat (MAV_TYPE_ONBOARD_CONTROLLER) is not one, so mavros hears no texts."""
    heartbeat(rig, mavlink.MAV_TYPE_ONBOARD_CONTROLLER)
    refused_param(rig)
    rig.run(0.5)
    assert rig.of('STATUSTEXT') == [], 'no STATUSTEXT to an onboard controller'
    heartbeat(rig, mavlink.MAV_TYPE_GCS)
    rig.run(0.1)
    texts = [m.text for m in rig.of('STATUSTEXT')]
    assert texts == [refusal(500.0)], 'the queued text once a GCS is heard: %s' % texts
    rig.run(3.0)  # no GCS HEARTBEAT for 3 s: disconnected
    start = len(rig.got)
    refused_param(rig, 501.0)
    rig.run(0.5)
    assert rig.of('STATUSTEXT', start) == [], 'the ground station went quiet 2.5 s ago'


def test_texts_older_than_5_s_are_dropped_and_several_go_out_20_a_second(rig):
    refused_param(rig, 499.0)
    rig.run(5.5)
    for value in (500.0, 501.0, 502.0):
        refused_param(rig, value)
    heartbeat(rig, mavlink.MAV_TYPE_GCS)
    rig.run(0.3)
    sent = [(t, m.text) for t, m in rig.got if m.get_type() == 'STATUSTEXT']
    assert [text for _, text in sent] == [refusal(v) for v in (500.0, 501.0, 502.0)], sent
    gaps = [b[0] - a[0] for a, b in zip(sent, sent[1:])]
    assert all(gap >= 1.0 / px4_figure('mavlink', 'statustext_stream_hz') - 1e-9 for gap in gaps), gaps


def recorded_boot_params():
    """{run: [(boot s, name, value, type, count, index)]}: what real PX4 sent unasked, per run."""
    with open(BOOT_PARAMS) as f:
        runs = json.load(f)['runs']
    types = {'INT32': mavlink.MAV_PARAM_TYPE_INT32, 'REAL32': mavlink.MAV_PARAM_TYPE_REAL32}
    return {run: [(p['boot_s'], p['param_id'], p['value'], types[p['param_type']], p['param_count'],
                   p['param_index']) for p in rec['param_values']] for run, rec in runs.items()}


def sent_value(msg):
    """A PARAM_VALUE's value as a number: INT32 travels as its bytes in the float, as PX4 sends it."""
    if msg.param_type == mavlink.MAV_PARAM_TYPE_INT32:
        return struct.unpack('<i', struct.pack('<f', msg.param_value))[0]
    return msg.param_value


def test_parameters_px4_sets_at_boot_are_announced_unasked_at_its_boot_times(rig):
    """PX4's parameter manager sends every parameter changed and not yet saved, in index order, a moment
    after a change (mavlink_parameters.cpp send_untransmitted): its start-up script's sensor ids and
    offsets at boot 1.00 and 1.03 s in the two recordings, the barometer's offset that SENS_BAR_AUTOCAL
    sets from the GPS altitude at 5.32 and 5.49 s. Same names, order, type, count and index as both
    runs (the bridge run also had EKF2_MAG_DECL, the mavros run not: left out); the values of the
    parameter table, except the barometer's offset, which is noise (6.10 and -12.21 Pa in the runs)."""
    rig.run(7.0)
    sent = [(t, m) for t, m in rig.got if m.get_type() == 'PARAM_VALUE']
    runs = recorded_boot_params()
    common = [p[1] for p in runs['takeoff-mavros-px4']]
    assert [p[1] for p in runs['takeoff-bridge-px4'] if p[1] in common] == common
    assert [m.param_id for _, m in sent] == common, [m.param_id for _, m in sent]
    by_name = {name: [p for run in runs.values() for p in run if p[1] == name] for name in common}
    for t, msg in sent:
        recorded = by_name[msg.param_id]
        times = [r[0] for r in recorded]
        assert min(times) - 0.05 <= t <= max(times) + 0.05, (msg.param_id, t, times)
        _, name, value, param_type, count, index = recorded[0]
        assert (msg.param_type, msg.param_count, msg.param_index) == (param_type, count, index), msg
        values = [r[2] for r in recorded]
        assert any(abs(sent_value(msg) - v) <= 1e-6 * max(1.0, abs(v)) for v in values), (name, msg, values)
        assert sent_value(msg) == pytest.approx(rig.ap.params[name], rel=1e-6), 'the table says what was sent'


def test_a_text_longer_than_50_characters_goes_out_in_chunks_of_one_id(rig):
    """PX4's STATUSTEXT stream (streams/STATUSTEXT.hpp): a text in 50-byte chunks, chunk_seq 0, 1, ...,
    all with the id its stream instance gives each text (0 for the link's first, then 1, ...; a short text
    takes one too); PX4's log queue holds 126 characters of a text (mavlink_log's char[127])."""
    heartbeat(rig, mavlink.MAV_TYPE_GCS)
    long_text = ''.join(chr(ord('a') + i % 26) for i in range(120))
    too_long = 'x' * 130
    rig.ap.text(mavlink.MAV_SEVERITY_INFO, 'short')
    rig.ap.text(mavlink.MAV_SEVERITY_WARNING, long_text)
    rig.ap.text(mavlink.MAV_SEVERITY_INFO, too_long)
    rig.run(0.3)
    sent = [(m.id, m.chunk_seq, m.severity, m.text) for m in rig.of('STATUSTEXT')]
    assert sent == [(0, 0, mavlink.MAV_SEVERITY_INFO, 'short'),
                    (1, 0, mavlink.MAV_SEVERITY_WARNING, long_text[:50]),
                    (1, 1, mavlink.MAV_SEVERITY_WARNING, long_text[50:100]),
                    (1, 2, mavlink.MAV_SEVERITY_WARNING, long_text[100:]),
                    (2, 0, mavlink.MAV_SEVERITY_INFO, 'x' * 50),
                    (2, 1, mavlink.MAV_SEVERITY_INFO, 'x' * 50),
                    (2, 2, mavlink.MAV_SEVERITY_INFO, 'x' * 26)], sent


def test_timesync_answer_is_addressed_to_the_requester(rig):
    """PX4's TIMESYNC answer fills MAVLink's extension fields target_system/target_component with the
    requester's ids (recorded: 1/240 to mavros); its own requests keep 0/0. pymavlink 2.4.49 has no such
    fields, so the test reads them from the frame: its payload's bytes 16 and 17, after tc1 and ts1."""
    rig.run(0.2)
    start = len(rig.got)
    rig.send(rig.codec.timesync_encode(0, 123456789))
    rig.run(0.02)
    answers = [m for m in rig.of('TIMESYNC', start) if m.tc1 != 0]
    assert len(answers) == 1 and answers[0].ts1 == 123456789
    payload = payload_of(answers[0])
    assert len(payload) == 18 and payload[16:18] == bytes(CLIENT), payload.hex()
    requests = [m for m in rig.of('TIMESYNC') if m.tc1 == 0]
    assert requests and all(len(payload_of(m)) <= 16 for m in requests), 'requests to all: no target'


def payload_of(msg):
    """A received MAVLink 2 frame's payload as sent (its length byte, after the 10-byte header)."""
    frame = bytes(msg.get_msgbuf())
    return frame[10:10 + frame[1]]


def test_home_position_from_2_4_s_after_boot_before_ready_as_px4():
    """PX4 SITL sets home as its estimator gets a position, 2.45 and 2.33 s after boot in the two
    recordings (HOME_POSITION.time_usec), before it is ready (about 4.4 s), and sends HOME_POSITION then
    and every 2 s; the simulator, with PX4's 5 s to ready, did not send it before 6 s."""
    rig = Rig(ready_delay_s=5.0)
    try:
        rig.run(6.5)
        homes = [(t, m) for t, m in rig.got if m.get_type() == 'HOME_POSITION']
        assert homes and abs(homes[0][0] - 2.4) <= 0.03, [round(t, 2) for t, _ in homes]
        assert homes[0][1].time_usec == 2400000, 'time_usec: the boot time home was set, as PX4'
        gaps = [b[0] - a[0] for a, b in zip(homes, homes[1:])]
        assert len(gaps) == 2 and all(abs(g - 2.0) <= 0.03 for g in gaps), gaps
    finally:
        rig.close()
