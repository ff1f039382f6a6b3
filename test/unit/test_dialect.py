"""The messages offboard_py.dialect adds to pymavlink's: PX4 sends them, pymavlink 2.4.49 lacks
them. Their definitions must frame as the MAVLink C library (PX4, mavros) does: the numbers below
are those of MAVLink's generated C headers (common/mavlink_msg_link_node_status.h and
mavlink_msg_time_estimate_to_target.h), not our code's."""

import pytest

from offboard_py import wire
from offboard_py.dialect import crc_extra, mavlink

# id, CRC_EXTRA, payload length, {field: wire offset} from the C headers
C_HEADERS = {
    'LINK_NODE_STATUS': (8, 117, 36, {'timestamp': 0, 'tx_rate': 8, 'rx_rate': 12, 'messages_sent': 16,
                                      'messages_received': 20, 'messages_lost': 24, 'rx_parse_err': 28,
                                      'tx_overflows': 30, 'rx_overflows': 32, 'tx_buf': 34, 'rx_buf': 35}),
    'TIME_ESTIMATE_TO_TARGET': (380, 232, 20, {'safe_return': 0, 'land': 4, 'mission_next_item': 8,
                                               'mission_end': 12, 'commanded_action': 16}),
    'PROTOCOL_VERSION': (300, 217, 22, {'version': 0, 'min_version': 2, 'max_version': 4, 'spec_version_hash': 6,
                                        'library_version_hash': 14}),
}


def _values(cls):
    """A distinct value for every field (arrays: distinct elements), the same sign as its type allows."""
    values, k = {}, 1
    for field, type_name in zip(cls.fieldnames, cls.fieldtypes):
        n = cls.array_lengths[cls.ordered_fieldnames.index(field)]
        sign = -1 if type_name.startswith('int') else 1
        values[field] = [sign * (k + i) for i in range(n)] if n else sign * k
        k += max(n, 1)
    return values


@pytest.mark.parametrize('name', sorted(C_HEADERS))
def test_added_message_frames_as_the_c_library(name):
    msg_id, crc, length, offsets = C_HEADERS[name]
    cls = mavlink.mavlink_map[msg_id]
    assert (cls.msgname, getattr(mavlink, 'MAVLINK_MSG_ID_' + name)) == (name, msg_id)
    assert cls.crc_extra == crc and wire.CRC_EXTRA[msg_id] == crc
    assert cls.unpacker.size == length
    # each field at the C header's offset: give every field a distinct value and find its bytes
    values = _values(cls)
    body = wire.payload(cls(**values))
    for field, offset in offsets.items():
        size = {'Q': 8, 'I': 4, 'i': 4, 'H': 2, 'B': 1}[cls.native_format.decode()[1 + cls.ordered_fieldnames.index(field)]]
        for i, value in enumerate(values[field] if isinstance(values[field], list) else [values[field]]):
            start = offset + i * size
            assert int.from_bytes(body[start:start + size], 'little', signed=True) == value, (field, i)


def test_crc_extra_follows_mavlinks_rule_for_messages_pymavlink_has():
    """The same computation gives pymavlink's own CRC_EXTRA, arrays included (extensions left out)."""
    cases = ((mavlink.MAVLink_system_time_message, ()), (mavlink.MAVLink_message_interval_message, ()),
             (mavlink.MAVLink_heartbeat_message, ()), (mavlink.MAVLink_local_position_ned_message, ()),
             (mavlink.MAVLink_autopilot_version_message, ('uid2',)),
             (mavlink.MAVLink_servo_output_raw_message, ('servo9_raw', 'servo10_raw', 'servo11_raw', 'servo12_raw',
                                                         'servo13_raw', 'servo14_raw', 'servo15_raw', 'servo16_raw')))
    for cls, extensions in cases:
        fields = []
        for name, type_name in zip(cls.fieldnames, cls.fieldtypes):
            if name in extensions:
                continue
            n = cls.array_lengths[cls.ordered_fieldnames.index(name)]
            type_name = 'uint8_t' if type_name == 'uint8_t_mavlink_version' else type_name
            fields.append((name, type_name, n) if n else (name, type_name))
        assert crc_extra(cls.msgname, fields) == cls.crc_extra, cls.msgname


@pytest.mark.parametrize('name', sorted(C_HEADERS))
def test_added_message_round_trips_through_pymavlink_and_wire(name):
    msg_id = C_HEADERS[name][0]
    cls = mavlink.mavlink_map[msg_id]
    values = list(_values(cls).values())
    sender = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    frame = bytes(getattr(sender, name.lower() + '_encode')(*values).pack(sender))
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    (decoded,) = parser.parse_buffer(frame)
    assert decoded.get_type() == name and [getattr(decoded, f) for f in cls.fieldnames] == values
    (split,) = wire.split(frame)
    assert split[0] == msg_id and wire.crc_ok(*split)
    assert [getattr(wire.decode(*split), f) for f in cls.fieldnames] == values
    assert wire.encode(getattr(sender, name.lower() + '_encode')(*values), sender.seq, 1, 1) == frame


def test_a_client_without_them_sees_unknown_ids():
    """pymavlink 2.4.49's own dialect has no id 8 or 380: such a client gets UNKNOWN_8, as it would from PX4."""
    import importlib.util
    spec = importlib.util.find_spec('pymavlink.dialects.v20.common')
    fresh = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fresh)
    assert 8 not in fresh.mavlink_map and 380 not in fresh.mavlink_map
    sender = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    frame = bytes(sender.time_estimate_to_target_encode(101, -1, -1, -1, -1).pack(sender))
    parser = fresh.MAVLink(None)
    parser.robust_parsing = True
    (decoded,) = parser.parse_buffer(frame)
    assert decoded.get_type() == 'UNKNOWN_380'


@pytest.mark.parametrize('name', sorted(C_HEADERS))
def test_added_message_send_writes_the_frame_as_pymavlinks_send_does(name):
    """MAVLink.<name>_send, as pymavlink generates one for every message: the frame of <name>_encode."""
    class Sink:
        def __init__(self):
            self.data = b''

        def write(self, data):
            self.data += bytes(data)
    cls = mavlink.mavlink_map[C_HEADERS[name][0]]
    values = list(_values(cls).values())
    sink = Sink()
    sender = mavlink.MAVLink(sink, srcSystem=1, srcComponent=1)
    getattr(sender, name.lower() + '_send')(*values)
    reference = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    assert sink.data == bytes(getattr(reference, name.lower() + '_encode')(*values).pack(reference))
    assert sender.seq == 1
