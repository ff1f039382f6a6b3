"""The project's MAVLink vocabulary: pymavlink's `development` dialect, MAVLink 2.

`development` is `common` plus the messages current PX4 sends that `common` lacks
(CURRENT_MODE and friends); two more that PX4 sends and this pymavlink lacks altogether
(LINK_NODE_STATUS, TIME_ESTIMATE_TO_TARGET) are added below. Every module that names a
MAVLink message, command, enum value or bit does it through `mavlink.<NAME>` from here
(`mavlink.MAV_CMD_NAV_LAND`, `mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE`,
`mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO`), never as a number, and builds and parses frames
with the same module.
"""

import inspect
import struct

from pymavlink.dialects.v20 import development as mavlink  # noqa: F401  (re-exported)

# Names from MAVLink's XML that this pymavlink release does not carry, named once here.
MAV_CMD_INJECT_FAILURE = 420   # common.xml: inject a failure (PX4, with SYS_FAILURE_EN)
FAILURE_UNIT_SENSOR_GYRO = 0   # common.xml FAILURE_UNIT (param1 of MAV_CMD_INJECT_FAILURE)
FAILURE_TYPE_OK = 0            # common.xml FAILURE_TYPE (param2): no failure
FAILURE_TYPE_OFF = 1           # common.xml FAILURE_TYPE: the unit is off

# PX4's "force" magic in COMPONENT_ARM_DISARM param2: arm or disarm whatever the checks say.
# MAVLink defines the value in the command's documentation, not as an enum.
ARM_DISARM_FORCE_MAGIC = 21196


# -- messages PX4 sends that this pymavlink release does not define -----------------------------
# PX4 main sends LINK_NODE_STATUS (id 8) and TIME_ESTIMATE_TO_TARGET (id 380) on its onboard
# link, and PROTOCOL_VERSION (300) when asked; all three are work-in-progress messages of
# common.xml that pymavlink 2.4.49 leaves out (a client built on it sees UNKNOWN_8 and
# UNKNOWN_380, as the reference census shows).
# They are added to the dialect here, in the shape of pymavlink's generated classes, so that
# the project builds, sends and decodes them like any other message.

_TYPES = {  # MAVLink type -> (struct code, size)
    'uint64_t': ('Q', 8), 'int64_t': ('q', 8), 'double': ('d', 8),
    'uint32_t': ('I', 4), 'int32_t': ('i', 4), 'float': ('f', 4),
    'uint16_t': ('H', 2), 'int16_t': ('h', 2), 'uint8_t': ('B', 1), 'int8_t': ('b', 1),
}


def crc_extra(name, fields):
    """MAVLink's CRC_EXTRA of a message definition (fields: (name, type[, array length]) in XML
    order, no extensions): the X.25 CRC of its name and of its fields' types, names and array
    lengths in wire order, folded into a byte."""
    crc = mavlink.x25crc((name + ' ').encode())
    for field in wire_order(fields):
        crc.accumulate((field[1] + ' ' + field[0] + ' ').encode())
        if len(field) > 2:
            crc.accumulate(bytes((field[2],)))
    return (crc.crc & 0xFF) ^ (crc.crc >> 8)


def wire_order(fields):
    """A message's fields in XML order -> wire order: by the size of their (element) type,
    largest first, stable (MAVLink's rule)."""
    return sorted(fields, key=lambda field: -_TYPES[field[1]][1])


def _define_message(msg_id, name, fields, doc):
    """Add a message to the dialect (fields: (name, type[, array length]) in XML order; numeric
    arrays, no extensions): its class (the attributes pymavlink's decoder, its encoder and
    offboard_py.wire use), MAVLINK_MSG_ID_<NAME>, its entry in mavlink_map and
    MAVLink.<name>_encode / _send."""
    names = [field[0] for field in fields]
    ordered = wire_order(fields)
    wire_names = [field[0] for field in ordered]
    lengths = [field[2] if len(field) > 2 else 0 for field in ordered]  # in wire order, as pymavlink's
    unpacker = struct.Struct('<' + ''.join(('%d' % n if n else '') + _TYPES[field[1]][0]
                                           for field, n in zip(ordered, lengths)))

    def __init__(self, *args, **kwargs):
        mavlink.MAVLink_message.__init__(self, msg_id, name)
        self._fieldnames = names
        self._instance_field = None
        self._instance_offset = -1
        values = dict(zip(names, args), **kwargs)
        for field_name in names:
            setattr(self, field_name, values[field_name])

    def pack(self, mav, force_mavlink1=False):
        items = []
        for field_name, n in zip(wire_names, lengths):
            value = getattr(self, field_name)
            items.extend(value[:n]) if n else items.append(value)
        return self._pack(mav, self.crc_extra, self.unpacker.pack(*items), force_mavlink1=force_mavlink1)

    cls = type('MAVLink_%s_message' % name.lower(), (mavlink.MAVLink_message,), {
        '__doc__': doc, '__init__': __init__, 'pack': pack,
        'id': msg_id, 'msgname': name, 'fieldnames': names,
        'ordered_fieldnames': wire_names,
        'fieldtypes': [field[1] for field in fields],
        'fielddisplays_by_name': {}, 'fieldenums_by_name': {}, 'fieldunits_by_name': {},
        'native_format': bytearray(('<' + ''.join(_TYPES[field[1]][0] for field in ordered)).encode()),
        'orders': [wire_names.index(n) for n in names],  # XML field i is wire field orders[i]
        'lengths': [n or 1 for n in lengths], 'array_lengths': lengths,
        'crc_extra': crc_extra(name, fields), 'unpacker': unpacker,
        'instance_field': None, 'instance_offset': -1,
    })

    def encode(self, *args, **kwargs):
        return cls(*args, **kwargs)

    def send(self, *args, force_mavlink1=False, **kwargs):
        return self.send(cls(*args, **kwargs), force_mavlink1=force_mavlink1)

    encode.__signature__ = _signature(names)
    setattr(mavlink, 'MAVLINK_MSG_ID_' + name, msg_id)
    setattr(mavlink, cls.__name__, cls)
    mavlink.mavlink_map[msg_id] = cls
    setattr(mavlink.MAVLink, name.lower() + '_encode', encode)
    setattr(mavlink.MAVLink, name.lower() + '_send', send)
    return cls


def _signature(names):
    """encode()'s signature, read by offboard_py.wire for defaults (there are none)."""
    params = [inspect.Parameter('self', inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    params += [inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD) for n in names]
    return inspect.Signature(params)


if not hasattr(mavlink, 'MAVLINK_MSG_ID_LINK_NODE_STATUS'):
    _define_message(8, 'LINK_NODE_STATUS', [
        ('timestamp', 'uint64_t'),  # "ms since boot" in the XML; PX4 fills it with hrt_absolute_time(), in us
        ('tx_buf', 'uint8_t'), ('rx_buf', 'uint8_t'),  # % free
        ('tx_rate', 'uint32_t'), ('rx_rate', 'uint32_t'),  # bytes/s
        ('rx_parse_err', 'uint16_t'), ('tx_overflows', 'uint16_t'), ('rx_overflows', 'uint16_t'),
        ('messages_sent', 'uint32_t'), ('messages_received', 'uint32_t'), ('messages_lost', 'uint32_t'),
    ], 'Status generated in each node in the communication chain and injected into the MAVLink stream (WIP).')

if not hasattr(mavlink, 'MAVLINK_MSG_ID_TIME_ESTIMATE_TO_TARGET'):
    _define_message(380, 'TIME_ESTIMATE_TO_TARGET', [
        ('safe_return', 'int32_t'), ('land', 'int32_t'), ('mission_next_item', 'int32_t'),
        ('mission_end', 'int32_t'), ('commanded_action', 'int32_t'),  # s; -1: none or not available
    ], 'Time estimates (s) for events and actions given the vehicle\'s state and position (WIP).')

if not hasattr(mavlink, 'MAVLINK_MSG_ID_PROTOCOL_VERSION'):
    _define_message(300, 'PROTOCOL_VERSION', [
        ('version', 'uint16_t'), ('min_version', 'uint16_t'), ('max_version', 'uint16_t'),  # x 100
        ('spec_version_hash', 'uint8_t', 8), ('library_version_hash', 'uint8_t', 8),  # git hashes, first 8 bytes
    ], 'The MAVLink versions a component speaks (WIP).')
