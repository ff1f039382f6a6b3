"""MAVLink frames on the wire: split a datagram into frames, check them, and encode messages.

pymavlink decodes every frame it is given into a message object; at PX4's 400 messages/s per
vehicle, most of them read by nobody, that would be most of a link's cost. Here:
- `split(data)` walks a datagram's frames by their headers (MAVLink 2 and 1), as the C
  library's parser frames them, and says where junk is, without decoding anything.
- `crc_ok(frame)` checks a frame's CRC (with its message's CRC_EXTRA) in C, so a link can
  count a frame nobody reads as valid or bad without decoding it.
- `decode(msg_id, frame)` is pymavlink's own MAVLink.decode() of a frame a link has chosen to read.
- `encode(msg, seq, system_id, component_id)` and `payload(msg)`: pymavlink's frame and payload of a
  message (for tests and tools; a link packs with its own codec, which numbers and signs).
- `Encoder(codec)`: pymavlink's encoders (`attitude_encode(...)`, ...) making `Outgoing` messages, kept as
  their arguments and framed from them by a link into pymavlink's bytes, without a pymavlink message
  object each (the simulated PX4's streams: some 780 messages a second a vehicle).
Everything here goes through pymavlink's public face (MAVLink.decode, msg.pack(mav), the message
classes' field tables): what saves time is not decoding what nobody reads, and not making objects
for what is only sent.

Signed frames are left to pymavlink and offboard_py.signing: encode() has no signature.
"""

import functools
import inspect
import struct

from offboard_py.dialect import FAST_FRAMES, frame_v2, mavlink

try:
    from fastcrc import crc16 as _fastcrc16  # what pymavlink itself uses when it is installed
except ImportError:  # pragma: no cover - pymavlink's pure-Python CRC then
    _fastcrc16 = None

MAGIC_V2 = mavlink.PROTOCOL_MARKER_V2      # 0xFD
MAGIC_V1 = mavlink.PROTOCOL_MARKER_V1      # 0xFE
HEADER_V2 = mavlink.HEADER_LEN_V2          # 10: magic, len, incompat, compat, seq, sys, comp, msgid x3
HEADER_V1 = mavlink.HEADER_LEN_V1          # 6: magic, len, seq, sys, comp, msgid
SIGNATURE_LEN = mavlink.MAVLINK_SIGNATURE_BLOCK_LEN  # 13
IFLAG_SIGNED = mavlink.MAVLINK_IFLAG_SIGNED

_crc_struct = struct.Struct('<H')

# CRC_EXTRA by message id; an id this dialect does not know is checked with 0, as the
# MAVLink C library (mavros, PX4) does.
CRC_EXTRA = {msg_id: cls.crc_extra for msg_id, cls in mavlink.mavlink_map.items()}
MSG_IDS = {cls.msgname: msg_id for msg_id, cls in mavlink.mavlink_map.items()}
# CRC_EXTRA as the byte the CRC runs over last, by message id
_CRC_EXTRA_BYTE = {msg_id: bytes((extra,)) for msg_id, extra in CRC_EXTRA.items()}


def crc16(data, crc=0xFFFF):
    """CRC-16/MCRF4XX (MAVLink's X.25 CRC) of data (bytes or bytearray), continuing from crc."""
    if _fastcrc16 is not None:
        return _fastcrc16.mcrf4xx(data if type(data) is bytes else bytes(data), crc)
    acc = mavlink.x25crc(b'')
    acc.crc = crc
    acc.accumulate(bytes(data))
    return acc.crc


def msg_id(name):
    """The message id of a message name ('HEARTBEAT' -> 0); KeyError if the dialect lacks it."""
    return MSG_IDS[name]


# -- receive ---------------------------------------------------------------------------------

def split(data):
    """The frames of one datagram, in order: a list of (msg_id, frame) with frame a bytes slice,
    or (None, junk) for bytes that are not a whole frame (a bad prefix, a truncated frame, a
    frame with incompatibility flags we do not know). Nothing is decoded or CRC-checked.

    Junk is skipped up to the next start byte, and a frame is skipped whole, as pymavlink's
    robust parser and the C library do; a UDP datagram never continues into the next one.
    """
    out = []
    i, n = 0, len(data)
    while i < n:
        magic = data[i]
        if magic == MAGIC_V2:
            if n - i < HEADER_V2 + 2:
                out.append((None, data[i:]))
                break
            flags = data[i + 2]
            size = HEADER_V2 + data[i + 1] + 2 + (SIGNATURE_LEN if flags & IFLAG_SIGNED else 0)
            if i + size > n:
                out.append((None, data[i:]))
                break
            if flags & ~IFLAG_SIGNED:
                out.append((None, data[i:i + size]))
            else:
                out.append((data[i + 7] | data[i + 8] << 8 | data[i + 9] << 16, data[i:i + size]))
            i += size
        elif magic == MAGIC_V1:
            if n - i < HEADER_V1 + 2:
                out.append((None, data[i:]))
                break
            size = HEADER_V1 + data[i + 1] + 2
            if i + size > n:
                out.append((None, data[i:]))
                break
            out.append((data[i + 5], data[i:i + size]))
            i += size
        else:
            starts = [j for j in (data.find(b'\xfd', i + 1), data.find(b'\xfe', i + 1)) if j >= 0]
            end = min(starts) if starts else n
            out.append((None, data[i:end]))
            i = end
    return out


def crc_ok(msg_id, frame):
    """True when a frame from split() carries the right CRC for its message id."""
    end = (HEADER_V2 if frame[0] == MAGIC_V2 else HEADER_V1) + frame[1]
    crc = crc16(bytes(frame[1:end]) + _CRC_EXTRA_BYTE.get(msg_id, b'\x00'))
    return crc == _crc_struct.unpack_from(frame, end)[0]


def decode(msg_id, frame):
    """The pymavlink message of an unsigned frame from split() whose CRC crc_ok() has checked: pymavlink's
    own MAVLink.decode(); None for a message id the dialect does not know or a signed frame (the link's
    codec then, which knows the signing key)."""
    if msg_id not in mavlink.mavlink_map or (frame[0] == MAGIC_V2 and frame[2] & IFLAG_SIGNED):
        return None
    return _DECODER.decode(bytearray(frame))


def decode_checked(frame):
    """pymavlink's message of a frame a link has already checked (its CRC, and its signature when the
    link signs), signed or not: for a reader that kept the frame (MavlinkLink.on_raw) and decodes it late."""
    return _DECODER.decode(bytearray(frame))


_DECODER = mavlink.MAVLink(None)  # no signing, no state: decode() only reads its header formats


# -- send ------------------------------------------------------------------------------------

_SIZES = {'char': 1, 'int8_t': 1, 'uint8_t': 1, 'int16_t': 2, 'uint16_t': 2,
          'int32_t': 4, 'uint32_t': 4, 'float': 4, 'int64_t': 8, 'uint64_t': 8, 'double': 8}


def payload_size(cls):
    """The untrimmed payload's length of a pymavlink message class, from its field tables."""
    types = dict(zip(cls.fieldnames, cls.fieldtypes))
    return sum(_SIZES[types[name]] * max(1, length) for name, length in zip(cls.ordered_fieldnames, cls.array_lengths))


def encode(msg, seq, system_id, component_id):
    """The unsigned MAVLink 2 frame pymavlink packs for msg (a pymavlink message or an Outgoing) with this
    sequence number and sender."""
    if type(msg) is Outgoing:
        return msg.frame(seq, system_id, component_id)
    codec = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
    codec.seq = seq
    return bytes(msg.pack(codec))


def payload(msg):
    """The untrimmed payload of a pymavlink message: its frame's, with the trailing zeros MAVLink 2
    drops put back."""
    if type(msg) is Outgoing:  # its whole payload straight from its arguments
        return msg._layout.payload(msg._args)
    body = encode(msg, 0, 0, 0)[HEADER_V2:-2]
    return body + bytes(payload_size(type(msg)) - len(body))


# -- messages kept as their encoder's arguments ---------------------------------------------------

class _Layout:
    """How a pymavlink message class lays out an encoder's arguments on the wire, from its public field
    tables: the argument of each wire position (fields by size, as `ordered_fieldnames`), which of them are
    arrays of numbers (one struct item an element; a char array is one bytes item), the defaults of the
    trailing arguments the encoder may leave out, and the class's struct, CRC_EXTRA and id."""

    def __init__(self, cls):
        self.cls = cls
        position = {name: i for i, name in enumerate(cls.fieldnames)}
        types = dict(zip(cls.fieldnames, cls.fieldtypes))
        self.order = [position[name] for name in cls.ordered_fieldnames]
        self.arrays = [length > 0 and types[name] != 'char'
                       for name, length in zip(cls.ordered_fieldnames, cls.array_lengths)]
        self.flat = not any(self.arrays)
        self.count = len(cls.fieldnames)
        params = list(inspect.signature(cls.__init__).parameters.values())[1:]
        self.defaults = tuple(param.default for param in params)
        self.pack, self.crc_extra, self.msg_id = cls.unpacker.pack, cls.crc_extra, cls.id

    def payload(self, args):
        """The whole (untrimmed) payload of the encoder's arguments."""
        if len(args) < self.count:
            args = args + self.defaults[len(args):]
        if self.flat:
            return self.pack(*[args[i] for i in self.order])
        values = []
        for i, array in zip(self.order, self.arrays):
            if array:
                values.extend(args[i])
            else:
                values.append(args[i])
        return self.pack(*values)


@functools.lru_cache(maxsize=None)
def _layout(cls):
    """The one _Layout of a message class, shared by every Encoder (a fleet's vehicles each have one)."""
    return _Layout(cls)


class Outgoing:
    """A message to send, kept as the arguments of its pymavlink encoder (`MAVLink.attitude_encode(...)`):
    a link frames it from them (frame(): the bytes pymavlink packs) without the message object pymavlink's
    encoder makes (every pymavlink encoder only makes that object). For the simulated PX4's streams, some
    780 messages a second a vehicle, that is about 5 % of its CPU (bench/results/2026-11-26-sim-saturation.md).
    Anything else asked of it (a field, get_type(), to_dict(), pack()) is asked of pymavlink's message of the
    same arguments, made on first use: a test or a log line sees what pymavlink's encoder would have
    returned."""

    __slots__ = ('_layout', '_args', '_message')

    def __init__(self, layout, args):
        self._layout, self._args, self._message = layout, args, None

    def frame(self, seq, system_id, component_id):
        """The unsigned MAVLink 2 frame, as pymavlink packs it with this sequence number and sender."""
        layout = self._layout
        return frame_v2(layout.msg_id, layout.crc_extra, layout.payload(self._args), seq, system_id,
                        component_id)[0]

    def message(self):
        """pymavlink's message of these arguments (made once)."""
        if self._message is None:
            self._message = self._layout.cls(*self._args)
        return self._message

    def __getattr__(self, name):
        if name.startswith('_'):  # pymavlink's public face only (and no recursion on a half-made copy)
            raise AttributeError(name)
        return getattr(self.message(), name)

    def __repr__(self):
        return 'Outgoing(%r)' % (self.message(),)


_CLASS_BY_ENCODER = {cls.msgname.lower() + '_encode': cls for cls in mavlink.mavlink_map.values()}


class Encoder:
    """pymavlink's encoders (`attitude_encode(...)` and the rest, as on a MAVLink codec) making Outgoing
    messages; any other attribute is the codec's. An encoder called with arguments by name makes
    pymavlink's own message. Without pymavlink's C CRC (dialect.FAST_FRAMES false) every encoder is the
    codec's own."""

    def __init__(self, codec):
        self.codec = codec

    def __getattr__(self, name):
        cls = _CLASS_BY_ENCODER.get(name) if FAST_FRAMES else None
        if cls is None:
            return getattr(self.codec, name)
        layout = _layout(cls)

        def encode(*args, **by_name):
            if by_name:
                return cls(*args, **by_name)
            return Outgoing(layout, args)
        setattr(self, name, encode)  # found here from now on, without __getattr__
        return encode
