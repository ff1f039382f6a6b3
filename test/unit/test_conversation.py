"""offboard_py.conversation offline: reading recordings (the pcap our relay writes, the references'
JSONL), the phases and figures of the real stack's recorded flight held to the numbers that
reference/px4-sitl-measured.md ("Recorded conversations") states for it, and the comparison."""

import os

import pytest

from offboard_py.conversation import analysis, compare, phases, reading
from offboard_py.conversation.recording import PcapWriter
from offboard_py.dialect import mavlink

REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..')
REAL = os.path.join(REPO, 'reference', 'conversations', 'takeoff-mavros-px4.compact.jsonl.xz')


@pytest.fixture(scope='module')
def real():
    return analysis.Summary(reading.read(REAL), 'real mavros + real PX4')


def frame(mav, msg):
    return bytes(msg.pack(mav))


def test_a_pcap_written_by_the_relay_reads_back_message_for_message(tmp_path):
    fcu = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    ros = mavlink.MAVLink(None, srcSystem=1, srcComponent=240)
    path = str(tmp_path / 'link.pcap')
    writer = PcapWriter(path)
    writer.write(100.0, True, frame(fcu, fcu.heartbeat_encode(2, 12, 29, 0x60000, 4)))
    writer.write(100.25, False, frame(ros, ros.set_position_target_local_ned_encode(
        0, 1, 1, 1, 3576, 0.0, 0.0, -2.0, 0, 0, 0, 0, 0, 0, 1.57, 0)))
    writer.write(100.5, True, frame(fcu, fcu.command_ack_encode(176, 0, 0, 0, 1, 240)))
    writer.close()
    got = reading.read(path)
    assert [(m.t, m.dir, m.sys, m.comp, m.type) for m in got] == [
        (0.0, 'fcu', 1, 1, 'HEARTBEAT'), (0.25, 'ros', 1, 240, 'SET_POSITION_TARGET_LOCAL_NED'),
        (0.5, 'fcu', 1, 1, 'COMMAND_ACK')]
    assert got[0].get('custom_mode') == 0x60000 and got[1].get('z') == -2.0 and got[2].get('command') == 176


def test_the_real_flight_has_its_phases_where_the_recording_says(real):
    """The node's SET_MODE at 11.06 s shown in the next HEARTBEAT, its arming at 16.11 s likewise; the
    connection about 1 s after PX4's boot (px4-sitl-measured.md, "Recorded conversations")."""
    names = [p.name for p in real.phases]
    assert names == list(phases.PHASES)
    start = {p.name: p.start for p in real.phases}
    assert 11.06 < start['OFFBOARD'] < 11.06 + 1.01, 'OFFBOARD in the first 1 Hz HEARTBEAT after the SET_MODE'
    assert 16.11 < start['armed hover'] < 16.11 + 1.01
    assert 0.9 < real.anchors['connected'] < 1.2


def test_the_real_flight_s_figures_are_the_recorded_ones(real):
    f = real.figures
    # PARAM_REQUEST_LIST at 11.0 s and the mission pulls at 16.0 s after the first packet, the pulls
    # of mission_type 1, 2 and 0 in that order, each answered by MISSION_COUNT 0 and acknowledged once
    assert abs(f['param/ros/list/after connected'].value + real.anchors['connected'] - 11.0) < 0.1
    assert f['mission/ros/order'].value == '1,2,0'
    for mtype in (1, 2, 0):
        key = 'mission/ros/%s' % analysis.mission_type_name(mtype)
        assert (f[key + '/count answered'].value, f[key + '/acks'].value) == (0, 1), key
    firsts = [f[k].value for k in f if k.startswith('mission/ros/') and k.endswith('/first/after connected')]
    assert len(firsts) == 3 and max(firsts) - min(firsts) < 0.002 and abs(min(firsts) + real.anchors['connected']
                                                                            - 16.0) < 0.1
    # SYSTEM_TIME at 1 a second from mavros, while the node hovers
    assert f['rate/ros/armed hover/SYSTEM_TIME'].value == pytest.approx(1.0, abs=0.1)


def test_a_missing_message_and_a_changed_rate_are_differences_and_accepting_them_is_explicit(real):
    without = [m for m in real.messages if not (m.dir == 'ros' and m.type == 'SYSTEM_TIME')]
    halved, seen = [], 0
    for m in without:  # every other HIGHRES_IMU dropped: 50 Hz -> 25 Hz
        if m.dir == 'fcu' and m.type == 'HIGHRES_IMU':
            seen += 1
            if seen % 2:
                continue
        halved.append(m)
    ours = analysis.Summary(halved, 'changed')
    differences = compare.compare(real, ours)
    keys = {d.key for d in differences}
    assert 'rate/ros/armed hover/SYSTEM_TIME' in keys
    assert 'rate/fcu/armed hover/HIGHRES_IMU' in keys
    assert compare.compare(real, real) == []
    left, taken, unused = compare.split_accepted(differences, {
        'rate/ros/*/SYSTEM_TIME': 'no SYSTEM_TIME', 'rate/fcu/*/GPS_RAW_INT': 'never differs here'})
    assert 'rate/fcu/armed hover/HIGHRES_IMU' in {d.key for d in left}
    assert {d.key for d, _ in taken} >= {'rate/ros/armed hover/SYSTEM_TIME'}
    assert unused == ['rate/fcu/*/GPS_RAW_INT']


@pytest.mark.parametrize('name, content, message', [
    ('garbled.pcap', b'\x00\x01\x02\x03' * 10, 'garbled.pcap'),
    ('short.pcap', bytes.fromhex('d4c3b2a1020004000000000000000000ffff000001000000') + b'\x01\x02', 'cut short'),
    ('bad.jsonl', b'{"t": 0.1, "dir": "fcu"}\n', 'bad.jsonl line 1'),
    ('bad.jsonl.xz', b'\xfd7zXZ\x00not really xz', 'broken xz data'),
])
def test_an_unreadable_recording_is_an_error_naming_the_file(tmp_path, name, content, message):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(reading.RecordingError, match=message.replace('.', r'\.')):
        reading.read(str(path))
