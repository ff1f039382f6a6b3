"""ULog, the file format of PX4's logger: the bytes of each kind of message the simulated PX4's logger writes.

As PX4 main 02e73e3b6f writes them (src/modules/logger/messages.h, logger.cpp write_header, write_info,
write_parameters, write_add_logged_msg; the format's description: docs.px4.io, dev_log/ulog_file_format):
a 16-byte file header (magic, version 1, the boot time in microseconds), then messages of a 3-byte header
(uint16 size of what follows, uint8 type, little-endian) and their payload. Which messages go into a log,
in what order and when is sim.logger's. Pure: no I/O.
"""

import struct

MAGIC = b'ULog\x01\x12\x35'
FILE_VERSION = 1
FILE_HEADER = struct.Struct('<7sBQ')
MESSAGE_HEADER = struct.Struct('<HB')

# ULogMessageType, those the simulator writes
FORMAT, DATA, INFO, PARAMETER, PARAMETER_DEFAULT = b'F', b'D', b'I', b'P', b'Q'
ADD_LOGGED_MSG, SYNC, LOGGING, FLAG_BITS = b'A', b'S', b'L', b'B'

COMPAT_FLAG0_DEFAULT_PARAMETERS = 1 << 0  # the log may hold PARAMETER_DEFAULT messages
SYNC_MAGIC = bytes((0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12))
DEFAULT_CURRENT_SETUP = 1 << 1  # ulog_parameter_default_type_t::current_setup (system is 1 << 0)
LOGGING_TEXT_MAX = 127  # log_message_s::text is char[128], NUL-terminated

_VALUES = {'int32_t': struct.Struct('<i'), 'uint32_t': struct.Struct('<I'), 'uint64_t': struct.Struct('<Q'),
           'float': struct.Struct('<f')}


def _message(kind, payload):
    return MESSAGE_HEADER.pack(len(payload), kind[0]) + payload


def file_header(timestamp_us):
    return FILE_HEADER.pack(MAGIC, FILE_VERSION, timestamp_us)


def flag_bits(compat_flags0=COMPAT_FLAG0_DEFAULT_PARAMETERS):
    """compat_flags[8], incompat_flags[8], appended_offsets[3]: what PX4 writes right after the header."""
    return _message(FLAG_BITS, bytes((compat_flags0,)) + bytes(7 + 8 + 3 * 8))


def format_definition(text):
    """A FORMAT message: 'topic:type field;type field;...' (sim.uorb_topics.Topic.format)."""
    return _message(FORMAT, text.encode('ascii'))


def _key_value(c_type, name, value):
    """key_len, 'type name', the value's bytes: INFO's, PARAMETER's and PARAMETER_DEFAULT's payload."""
    if c_type == 'char':
        data = value.encode('utf-8')
        key = 'char[%d] %s' % (len(data), name)
    else:
        data = _VALUES[c_type].pack(value)
        key = '%s %s' % (c_type, name)
    key = key.encode('ascii')
    return bytes((len(key),)) + key + data


def info(c_type, name, value):
    """An INFO message; c_type 'char' for a string, or 'int32_t', 'uint32_t', 'uint64_t'."""
    return _message(INFO, _key_value(c_type, name, value))


def parameter(c_type, name, value):
    """A PARAMETER message; c_type 'int32_t' or 'float'."""
    return _message(PARAMETER, _key_value(c_type, name, value))


def parameter_default(default_types, c_type, name, value):
    return _message(PARAMETER_DEFAULT, bytes((default_types,)) + _key_value(c_type, name, value))


def add_logged_msg(msg_id, multi_id, topic_name):
    """ADD_LOGGED_MSG: the subscription `msg_id` (what DATA messages name) to instance `multi_id` of a topic."""
    return _message(ADD_LOGGED_MSG, struct.pack('<BH', multi_id, msg_id) + topic_name.encode('ascii'))


def data_header(msg_id, size):
    """The first 5 bytes of a DATA message whose sample is `size` bytes: its header and msg_id."""
    return struct.pack('<HBH', size + 2, DATA[0], msg_id)


def logging(level, timestamp_us, text):
    """A LOGGING message: level as PX4 writes it (the kernel's levels as the characters '0'..'7'), the time in
    microseconds since boot and the text (at most LOGGING_TEXT_MAX bytes)."""
    data = text.encode('utf-8')[:LOGGING_TEXT_MAX]
    return _message(LOGGING, struct.pack('<BQ', ord('0') + level, timestamp_us) + data)


def sync():
    return _message(SYNC, SYNC_MAGIC)
