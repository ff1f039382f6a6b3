"""The wire layer (offboard_py.wire) and the link's use of it, datagram by datagram.

- encode() and payload() are pymavlink's frame and payload, for every message of the dialect, and the
  dialect's own packer (offboard_py.dialect) makes pymavlink's bytes.
- Each link numbers its frames 0, 1, ... 255, 0 (PX4 and mavros count per channel; a
  receiver measures packet loss from the gaps). Before this, every frame said seq 0.
- split() frames a datagram as the C library's parser does; crc_ok() checks a frame's CRC.
- decode() must make the message object pymavlink's decode() makes, for every message of the
  dialect, whole or trimmed, MAVLink 2 or 1, from the frames split() gives.
- A link decodes only the types its handlers read, and still counts and checks the rest.
"""

import copy
import inspect
import random
import socket
import struct
import time

import pytest

from offboard_py import wire
from offboard_py.dialect import mavlink
from offboard_py.mavlink_link import NEEDED_RECHECK_S, MavlinkLink

INT_RANGES = {'int8_t': (-128, 127), 'uint8_t': (0, 255), 'int16_t': (-32768, 32767), 'uint16_t': (0, 65535),
              'int32_t': (-2 ** 31, 2 ** 31 - 1), 'uint32_t': (0, 2 ** 32 - 1),
              'int64_t': (-2 ** 63, 2 ** 63 - 1), 'uint64_t': (0, 2 ** 64 - 1)}


def _value(rng, type_name):
    if type_name in ('float', 'double'):
        return rng.choice((0.0, 1.5, -3.25, 1e6))
    low, high = INT_RANGES[type_name]
    return rng.choice((0, 0, low, high, rng.randint(low, high)))


def sample_message(cls, rng):
    """An instance of a pymavlink message class with random field values (zeros often, so
    that trailing-zero trimming is exercised)."""
    return cls(*sample_args(cls, rng))


def sample_args(cls, rng):
    """Random arguments of a pymavlink message class's constructor (and its encoder), in its order."""
    args = []
    for name, type_name in zip(cls.fieldnames, cls.fieldtypes):
        length = cls.array_lengths[cls.ordered_fieldnames.index(name)]
        if type_name == 'char':
            text = ''.join(rng.choice('abcXYZ_') for _ in range(rng.randint(0, max(1, length))))
            args.append(text.encode()[:max(1, length)])
        elif length:
            args.append([_value(rng, type_name) for _ in range(length)])
        else:
            args.append(_value(rng, type_name))
    return args


def _all_zero(cls):
    return cls(*_zero_args(cls))


def _zero_args(cls):
    return [(b'' if t == 'char' else [0] * n if n else 0) for t, n in (
        (t, cls.array_lengths[cls.ordered_fieldnames.index(f)]) for f, t in zip(cls.fieldnames, cls.fieldtypes))]


def _required(cls):
    """How many of the constructor's arguments have no default (the rest are MAVLink 2 extensions)."""
    return sum(1 for p in inspect.signature(cls.__init__).parameters.values()
               if p.default is inspect.Parameter.empty) - 1  # self


@pytest.mark.parametrize('msg_id', sorted(mavlink.mavlink_map))
def test_an_outgoing_message_is_framed_as_pymavlink_packs_it(msg_id):
    """wire.Encoder's messages (wire.Outgoing, what the simulated PX4 streams) are framed from their
    arguments into pymavlink's bytes: sampled, all-zero, and with the extension fields left out; asked
    anything else, they answer as pymavlink's message of the same arguments."""
    rng = random.Random(10000 + msg_id)
    cls = mavlink.mavlink_map[msg_id]
    encode = getattr(wire.Encoder(mavlink.MAVLink(None, srcSystem=42, srcComponent=190)),
                     cls.msgname.lower() + '_encode')
    sampled = sample_args(cls, rng)
    for seq, args in ((0, sampled), (77, sample_args(cls, rng)), (255, _zero_args(cls)),
                      (3, sampled[:_required(cls)])):
        msg = encode(*args)
        assert type(msg) is wire.Outgoing, cls.msgname
        reference = mavlink.MAVLink(None, srcSystem=42, srcComponent=190)
        reference.seq = seq
        expected = cls(*args).pack(reference)  # pymavlink as installed
        assert msg.frame(seq, 42, 190) == expected, cls.msgname
        assert wire.encode(msg, seq, 42, 190) == expected, cls.msgname
        assert wire.payload(msg) == wire.payload(cls(*args)), cls.msgname
        assert msg.get_type() == cls.msgname and msg.to_dict() == cls(*args).to_dict()
    assert type(encode(*sampled[:-1], **{cls.fieldnames[-1]: sampled[-1]})) is cls, 'by name: pymavlink\'s own'


def test_a_link_frames_outgoing_messages_in_its_sequence_and_signs_them_as_pymavlink():
    link = MavlinkLink(('127.0.0.1', 0), None, system_id=3, component_id=1, learn_remote=False)
    try:
        encoder = wire.Encoder(link.mav)
        plain = [link._pack(encoder.attitude_encode(1000 + i, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0)) for i in range(2)]
        key = bytes(range(32))
        link.enable_signing(key, timestamp=1000)
        signed = link._pack(encoder.attitude_encode(1002, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0))
    finally:
        link.close()
    assert [f[4] for f in plain + [signed]] == [0, 1, 2], 'one sequence for both kinds of message'
    assert plain[0] == wire.encode(mavlink.MAVLink_attitude_message(1000, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0), 0, 3, 1)
    assert signed[2] & wire.IFLAG_SIGNED
    reader = mavlink.MAVLink(None)
    reader.signing.secret_key = key
    (decoded,) = reader.parse_buffer(signed)
    assert decoded.time_boot_ms == 1002 and reader.signing.badsig_count == 0


@pytest.mark.parametrize('msg_id', sorted(mavlink.mavlink_map))
def test_payload_is_pymavlinks_whole_payload(msg_id):
    """wire.payload: the frame's trimmed payload with MAVLink 2's dropped zeros put back, as long as
    pymavlink's struct for the class."""
    rng = random.Random(msg_id)
    cls = mavlink.mavlink_map[msg_id]
    for seq, msg in ((0, sample_message(cls, rng)), (255, _all_zero(cls))):
        reference = mavlink.MAVLink(None, srcSystem=42, srcComponent=190)
        reference.seq = seq
        expected = copy.deepcopy(msg).pack(reference)
        assert wire.encode(msg, seq, 42, 190) == expected, cls.msgname
        body = wire.payload(msg)
        assert len(body) == wire.payload_size(cls) == cls.unpacker.size, cls.msgname
        assert body.startswith(expected[wire.HEADER_V2:-2]) and not body[len(body.rstrip(b'\x00')):].strip(b'\x00')


def test_importing_offboard_py_patches_nothing():
    """pymavlink, the generated dialect and rospy stay as installed: our speed comes from functions of ours
    (STYLE.md 8), so a user's test that imports the test kit gets the libraries it installed."""
    import offboard_py.signing  # noqa: F401
    import offboard_py.testing.sim_client  # noqa: F401
    from pymavlink.dialects.v20 import common
    assert mavlink.MAVLink_message._pack.__module__ == mavlink.__name__
    assert common.MAVLink_message._pack.__module__ == common.__name__
    link = MavlinkLink(('127.0.0.1', 0), None, system_id=3, component_id=1, learn_remote=False)
    try:
        link.enable_signing(bytes(range(32)), timestamp=1000)
        assert 'check_signature' not in vars(link.mav), 'the codec checks with pymavlink\'s own method'
    finally:
        link.close()


def _raw_frame(msg_id, body, rng, v1=False):
    """A frame of any payload bytes with a right CRC: what a sender's trimmed or garbled payload looks like."""
    cls = mavlink.mavlink_map[msg_id]
    if v1:
        header = bytes((wire.MAGIC_V1, len(body), rng.getrandbits(8), rng.randint(1, 255), rng.getrandbits(8), msg_id))
    else:
        header = bytes((wire.MAGIC_V2, len(body), 0, rng.choice((0, 1)), rng.getrandbits(8), rng.randint(1, 255),
                        rng.getrandbits(8), msg_id & 0xFF, msg_id >> 8 & 0xFF, msg_id >> 16))
    return header + body + struct.pack('<H', wire.crc16(header[1:] + body + bytes((cls.crc_extra,))))


def _as_compared(msg):
    """A message object's whole state, header included, in a form where NaN equals NaN."""
    state = dict(msg.__dict__)
    header = state.pop('_header').__dict__
    return type(msg), repr(sorted(state.items())), sorted(header.items())


@pytest.mark.parametrize('msg_id', sorted(mavlink.mavlink_map))
def test_decode_is_pymavlinks_message(msg_id):
    """decode() gives what pymavlink's decode() gives: whole payloads of sampled values, trimmed
    payloads (MAVLink 2 drops trailing zeros; an older sender's lacks extension fields), longer
    ones (a newer sender's extensions), random bytes (NaNs, odd strings), MAVLink 1 frames."""
    rng = random.Random(msg_id + 2000)
    cls = mavlink.mavlink_map[msg_id]
    reference = mavlink.MAVLink(None)
    size = wire.payload_size(cls)
    bodies = [wire.payload(sample_message(cls, rng)) for _ in range(3)]
    bodies += [body.rstrip(b'\x00') or body[:1] for body in bodies]
    bodies += [bytes(rng.getrandbits(8) for _ in range(n)) for n in (1, rng.randint(1, size), size, min(255, size + 4))]
    for i, body in enumerate(bodies):
        data = _raw_frame(msg_id, body, rng, v1=msg_id < 256 and i % 3 == 0)
        [(split_id, frame)] = wire.split(data)
        assert split_id == msg_id and wire.crc_ok(msg_id, frame)
        try:
            expected = _as_compared(reference.decode(bytearray(frame)))
        except Exception as err:  # a string field that is not UTF-8: both must refuse it alike
            with pytest.raises(type(err)):
                wire.decode(msg_id, frame)
            continue
        assert _as_compared(wire.decode(msg_id, frame)) == expected, (cls.msgname, body)


def test_decode_leaves_signed_frames_and_unknown_ids_to_pymavlink():
    rng = random.Random(5)
    body = wire.payload(HB)
    signed = bytearray(_raw_frame(0, body, rng))
    signed[2] = wire.IFLAG_SIGNED
    assert wire.decode(0, bytes(signed) + bytes(wire.SIGNATURE_LEN)) is None
    assert wire.decode(70000, _raw_frame(0, body, rng)) is None


def test_a_link_numbers_its_frames():
    link = MavlinkLink(('127.0.0.1', 0), None, system_id=3, component_id=1, learn_remote=False)
    try:
        seqs = [link._pack(link.mav.heartbeat_encode(2, 12, 0, 0, 0))[4] for _ in range(300)]
    finally:
        link.close()
    assert seqs[:3] == [0, 1, 2] and seqs[255:258] == [255, 0, 1], 'seq counts per frame and wraps at 256'


def frame(msg, seq=0, system_id=1):
    return wire.encode(msg, seq, system_id, 1)


HB = mavlink.MAVLink_heartbeat_message(2, 12, 29, 0x03040000, 3, 3)
ATT = mavlink.MAVLink_attitude_message(1000, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0)


def test_split_frames_junk_and_truncation():
    v1 = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    v1.WIRE_PROTOCOL_VERSION = '1.0'
    v1_frame = HB.pack(v1, force_mavlink1=True)
    data = b'\x00\x01junk' + frame(HB) + v1_frame + frame(ATT) + frame(ATT)[:-3]
    parts = wire.split(data)
    assert [p[0] for p in parts] == [None, mavlink.MAVLINK_MSG_ID_HEARTBEAT, mavlink.MAVLINK_MSG_ID_HEARTBEAT,
                                     mavlink.MAVLINK_MSG_ID_ATTITUDE, None]
    assert parts[0][1] == b'\x00\x01junk' and parts[2][1] == v1_frame
    assert all(wire.crc_ok(i, f) for i, f in parts if i is not None)
    assert b''.join(f for _, f in parts) == data, 'every byte is accounted for'


def test_split_signed_length_and_unknown_flags():
    signed = bytearray(frame(HB))
    signed[2] = mavlink.MAVLINK_IFLAG_SIGNED
    signed += bytes(13)
    odd = bytearray(frame(HB))
    odd[2] = 0x02
    parts = wire.split(bytes(signed) + bytes(odd) + frame(ATT))
    assert [(p[0], len(p[1])) for p in parts] == [(0, len(signed)), (None, len(odd)),
                                                  (mavlink.MAVLINK_MSG_ID_ATTITUDE, len(frame(ATT)))]


def test_crc_ok_catches_a_flipped_bit_and_uses_crc_extra():
    good = frame(ATT)
    assert wire.crc_ok(mavlink.MAVLINK_MSG_ID_ATTITUDE, good)
    bad = bytearray(good)
    bad[12] ^= 0x10
    assert not wire.crc_ok(mavlink.MAVLINK_MSG_ID_ATTITUDE, bytes(bad))
    assert not wire.crc_ok(mavlink.MAVLINK_MSG_ID_HEARTBEAT, good), 'another id means another CRC_EXTRA'


@pytest.fixture
def link():
    endpoint = MavlinkLink(('127.0.0.1', 0), None, system_id=255, component_id=1)
    endpoint.got = []
    endpoint.on('HEARTBEAT', endpoint.got.append)
    yield endpoint
    endpoint.close()


def test_link_decodes_only_what_it_reads(link, monkeypatch):
    decoded = []
    real_decode = wire.decode
    monkeypatch.setattr(wire, 'decode', lambda msg_id, data: decoded.append(msg_id) or real_decode(msg_id, data))
    link.handle_datagram(frame(ATT) + frame(HB, seq=1) + frame(ATT, seq=2), ('127.0.0.1', 14580))
    assert [m.get_type() for m in link.got] == ['HEARTBEAT'] and link.got[0].get_seq() == 1
    assert decoded == [mavlink.MAVLINK_MSG_ID_HEARTBEAT], 'ATTITUDE has no reader: framed and checked, not decoded'
    assert link.stats['received'] == 3 and link.stats['bad_frames'] == 0
    assert link.remote == ('127.0.0.1', 14580)


def test_link_decodes_a_type_only_while_a_handler_needs_it(link, monkeypatch):
    decoded, needed, got = [], [False], []
    real_decode = wire.decode
    monkeypatch.setattr(wire, 'decode', lambda msg_id, data: decoded.append(msg_id) or real_decode(msg_id, data))
    link.on('ATTITUDE', got.append, needed=lambda: needed[0])
    link.handle_datagram(frame(ATT) + frame(HB, seq=1), ('127.0.0.1', 14580))
    assert decoded == [mavlink.MAVLINK_MSG_ID_HEARTBEAT] and got == [], 'not needed: checked and counted only'
    assert link.stats['received'] == 2
    needed[0] = True
    link.handle_datagram(frame(ATT, seq=2), ('127.0.0.1', 14580))
    assert got == [], 'needed() is not asked at every frame'
    time.sleep(NEEDED_RECHECK_S * 1.2)
    link.handle_datagram(frame(ATT, seq=3), ('127.0.0.1', 14580))
    assert [m.get_type() for m in got] == ['ATTITUDE'] and link.stats['received'] == 4, \
        'asked again NEEDED_RECHECK_S later'
    needed[0] = False
    link.needs_changed()
    link.handle_datagram(frame(ATT, seq=4), ('127.0.0.1', 14580))
    assert len(got) == 1, 'and at once after needs_changed()'
    link.on('ATTITUDE', lambda msg: None)  # a handler that always reads it
    link.handle_datagram(frame(ATT, seq=5), ('127.0.0.1', 14580))
    assert len(got) == 2, 'one handler that always reads a type decodes it for all of them'


def _one_frame_datagrams(rng, count):
    """PX4's framing (a message a datagram) with what a link meets on it: read and unread types, kept
    frames, lost and repeated sequence numbers, another system, another component, bad CRCs, MAVLink 1."""
    att_q = mavlink.MAVLink_attitude_quaternion_message(1000, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    out, seq = [], 0
    for _ in range(count):
        seq = (seq + rng.choice((1, 1, 1, 2, 0, 7))) & 0xFF
        msg = rng.choice((HB, ATT, ATT, att_q))
        system = rng.choice((1, 1, 1, 1, 2))
        data = bytearray(wire.encode(msg, seq, system, rng.choice((1, 1, 1, 190))))
        if rng.random() < 0.05:
            data[-1] ^= 0xFF  # a bad CRC
        if rng.random() < 0.03:
            mav1 = mavlink.MAVLink(None, srcSystem=system, srcComponent=1)
            mav1.WIRE_PROTOCOL_VERSION = '1.0'
            data = bytearray(msg.pack(mav1))
        out.append(bytes(data))
    return out


def test_one_frame_datagrams_are_taken_as_the_general_walk_takes_them(monkeypatch):
    """handle_datagram's short way for a lone unsigned frame nobody decodes now (_skim) counts, hooks,
    orders and answers exactly as the walk over a datagram's frames does: same stats, same calls."""
    datagrams = _one_frame_datagrams(random.Random(7), 3000)

    def run(short_way):
        endpoint = MavlinkLink(('127.0.0.1', 0), None, system_id=255, component_id=1, peer=(1, 1))
        calls = []
        endpoint.on('HEARTBEAT', lambda msg: calls.append(('HEARTBEAT', msg.get_seq())))
        endpoint.on('ATTITUDE', lambda msg: calls.append(('ATTITUDE', msg.get_seq())), needed=lambda: False)
        endpoint.on_raw('ATTITUDE_QUATERNION', lambda data: calls.append(('kept', bytes(data))))
        endpoint.on_frames(lambda data: calls.append(('frame', bytes(data))))
        endpoint.on_datagram = lambda data: calls.append(('datagram', len(data)))
        if not short_way:
            monkeypatch.setattr(endpoint, '_skim', lambda data, sender: False)
        for i, data in enumerate(datagrams):
            endpoint.handle_datagram(data, ('127.0.0.1', 14580 + i % 3))
            calls.append(('remote', endpoint.remote))
        endpoint.close()
        return calls, dict(endpoint.stats), endpoint.remote

    short, walked = run(True), run(False)
    assert short[1] == walked[1] and short[2] == walked[2]
    assert short[0] == walked[0]
    assert short[1]['dropped'] > 0 and short[1]['bad_frames'] > 0 and short[1]['other_system'] > 0


def test_receive_reads_every_pending_datagram_and_stops_without_waiting(link):
    """receive() asks poll() whether another datagram waits instead of reading until EAGAIN."""
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for seq in range(3):
        sender.sendto(frame(HB, seq=seq), link.bind)
    time.sleep(0.05)
    assert link.receive() == 3 and [m.get_seq() for m in link.got] == [0, 1, 2]
    assert link.receive() == 0, 'nothing pending: returns at once'
    sender.close()


def test_link_gives_kept_frames_undecoded_in_their_turn(link, monkeypatch):
    """on_raw(): every valid frame of the type, decoded or not, before the handlers of its own message and
    after those of the messages before it in the datagram; a bad one is not given."""
    decoded, calls = [], []
    real_decode = wire.decode
    monkeypatch.setattr(wire, 'decode', lambda msg_id, data: decoded.append(msg_id) or real_decode(msg_id, data))
    link.on_raw('ATTITUDE', lambda data: calls.append(('raw', data[4])))
    link.on('HEARTBEAT', lambda msg: calls.append(('HEARTBEAT', msg.get_seq())))
    bad = bytearray(frame(ATT, seq=3))
    bad[-1] ^= 0xFF
    link.handle_datagram(frame(HB, seq=1) + frame(ATT, seq=2) + bytes(bad), ('127.0.0.1', 14580))
    assert calls == [('HEARTBEAT', 1), ('raw', 2)] and decoded == [mavlink.MAVLINK_MSG_ID_HEARTBEAT]
    assert link.stats['received'] == 2 and link.stats['bad_frames'] == 1
    got = []
    link.on('ATTITUDE', lambda msg: got.append(msg.get_seq()) or calls.append(('ATTITUDE', msg.get_seq())))
    link.handle_datagram(frame(ATT, seq=4), ('127.0.0.1', 14580))
    assert calls[-2:] == [('raw', 4), ('ATTITUDE', 4)], 'kept first, then the handlers of the same message'
    assert wire.decode_checked(frame(ATT, seq=4)).get_seq() == 4


def test_link_counts_bad_frames_and_junk_moves_nothing(link):
    bad = bytearray(frame(ATT))
    bad[-1] ^= 0xFF
    link.handle_datagram(bytes(bad) + b'\xfd\x09', ('127.0.0.1', 9999))
    assert link.stats['bad_frames'] == 2 and link.stats['received'] == 0
    assert link.remote is None, 'a datagram without one valid frame must not move the learned remote'
    unknown = bytearray(frame(HB))
    unknown[7:10] = struct.pack('<I', 70000)[:3]  # an id the dialect lacks, CRC now wrong too
    link.handle_datagram(bytes(unknown), ('127.0.0.1', 9999))
    assert link.stats['bad_frames'] == 3 and link.remote is None


def test_link_counts_frames_lost_by_their_sequence_numbers(link):
    link.handle_datagram(frame(HB, seq=254) + frame(ATT, seq=255) + frame(ATT, seq=2), ('127.0.0.1', 14580))
    assert link.stats['dropped'] == 2, '0 and 1 are missing (the counter wraps at 256)'
    link.handle_datagram(frame(HB, seq=7, system_id=42), ('127.0.0.1', 14580))
    assert link.stats['dropped'] == 2, 'another sender has its own sequence'
