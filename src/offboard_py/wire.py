"""MAVLink frames on the wire: split a datagram into frames, check them, and encode messages.

pymavlink decodes every frame it is given into a message object and packs through a chain
of helper objects; at PX4's 400 messages/s per vehicle that is most of a link's cost. Here:
- `split(data)` walks a datagram's frames by their headers (MAVLink 2 and 1), as the C
  library's parser frames them, and says where junk is, without decoding anything.
- `crc_ok(frame)` checks a frame's CRC (with its message's CRC_EXTRA) in C, so a link can
  count a frame nobody reads as valid or bad without decoding it.
- `decode(msg_id, frame)` turns a checked, unsigned frame into the message object pymavlink's
  MAVLink.decode() makes of it (same class, fields, header, buffers), with one struct call and
  a field order worked out once per message type.
- `encode(msg, seq, system_id, component_id)` packs a pymavlink message (or a `Packed` one)
  into the MAVLink 2 frame pymavlink would make (byte for byte), with the link's own sequence
  number.
- `PackingCodec` stands in for a pymavlink codec where messages are built only to be sent: its
  `xxx_encode(...)` methods take pymavlink's arguments and return a `Packed` message (its class,
  arguments and payload), packed by one struct call from code made once per message type out
  of pymavlink's own field tables, without pymavlink's message objects.

Signed frames are left to pymavlink and offboard_py.signing: encode() has no signature.
"""

import inspect
import operator
import struct

from offboard_py.dialect import mavlink

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

_header_v2 = struct.Struct('<BBBBBBBHB')
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


class _Reader:
    """How one message type's payload becomes pymavlink's constructor arguments: the steps of
    pymavlink's decode() (zero-fill a trimmed payload, unpack, put the wire-ordered fields back
    in the XML's order, gather arrays, strip strings' trailing NULs), worked out once."""

    def __init__(self, cls):
        self.cls = cls
        self.size = cls.unpacker.size
        self.unpack = cls.unpacker.unpack
        sample = self.unpack(bytes(self.size))  # which unpacked items are strings (bytes)
        if sum(cls.lengths) == len(cls.lengths):  # no arrays: a reordering
            self.spans = None
            self.order = operator.itemgetter(*cls.orders) if len(cls.orders) > 1 else (lambda t: (t[cls.orders[0]],))
            self.strings = [i for i, j in enumerate(cls.orders) if isinstance(sample[j], bytes)]
        else:
            self.spans, self.strings = [], []
            for i, order in enumerate(cls.orders):
                length, tip = cls.lengths[order], sum(cls.lengths[:order])
                whole = length == 1 or isinstance(sample[tip], bytes)
                self.spans.append((tip, tip + (1 if whole else length), whole))
                if isinstance(sample[tip], bytes):
                    self.strings.append(i)

    def fields(self, body):
        if len(body) < self.size:
            body = body + bytes(self.size - len(body))
        elif len(body) > self.size:
            body = body[:self.size]
        t = self.unpack(body)
        if self.spans is None:
            values = list(self.order(t))
        else:
            values = [t[tip] if whole else list(t[tip:end]) for tip, end, whole in self.spans]
        for i in self.strings:
            values[i] = values[i].rstrip(b'\x00')
        return values


_READERS = {}


def decode(msg_id, frame):
    """The pymavlink message of an unsigned frame from split() whose CRC crc_ok() has checked, as
    MAVLink.decode(bytearray(frame)) makes it (class, fields, _header, _msgbuf, _payload, _crc);
    None for a message id the dialect does not know or a signed frame (pymavlink's decode then)."""
    reader = _READERS.get(msg_id)
    if reader is None:
        cls = mavlink.mavlink_map.get(msg_id)
        if cls is None:
            return None
        reader = _READERS[msg_id] = _Reader(cls)
    if frame[0] == MAGIC_V2:
        if frame[2] & IFLAG_SIGNED:
            return None
        start, incompat, compat, seq, system, component = 10, frame[2], frame[3], frame[4], frame[5], frame[6]
    else:
        start, incompat, compat, seq, system, component = 6, 0, 0, frame[2], frame[3], frame[4]
    length = frame[1]
    msg = reader.cls(*reader.fields(frame[start:start + length]))
    buf = bytearray(frame)
    msg._msgbuf = buf
    msg._payload = buf[6:-2]  # sic: pymavlink slices from 6 whatever the header's length
    msg._crc = frame[-2] | frame[-1] << 8
    msg._header = mavlink.MAVLink_header(msg_id, incompat, compat, length, seq, system, component)
    return msg


# -- send ------------------------------------------------------------------------------------

def _payload_only(_mav, _crc_extra, payload, force_mavlink1=False):
    return payload


def payload(msg):
    """The payload of a pymavlink message (untrimmed), as its generated pack() computes it.

    pack() builds the payload and hands it to self._pack(); for the moment of the call the
    instance's _pack returns the payload instead of building pymavlink's header objects.
    """
    msg._pack = _payload_only
    try:
        return msg.pack(None)
    finally:
        del msg._pack


def frame(msg_id, body, seq, system_id, component_id):
    """The unsigned MAVLink 2 frame of a message's untrimmed payload."""
    trimmed = body.rstrip(b'\x00') or body[:1]  # MAVLink 2 drops trailing zeros, keeps one byte
    header = _header_v2.pack(MAGIC_V2, len(trimmed), 0, 0, seq, system_id, component_id, msg_id & 0xFFFF,
                             msg_id >> 16)
    # one CRC call over everything after the magic byte, then CRC_EXTRA (a message's hot path:
    # the simulator packs about 460 a second)
    crc = crc16(header[1:] + trimmed + _CRC_EXTRA_BYTE[msg_id])
    return header + trimmed + _crc_struct.pack(crc)


def encode(msg, seq, system_id, component_id):
    """The unsigned MAVLink 2 frame of msg (a pymavlink message or a Packed one), byte for byte
    what pymavlink packs."""
    if type(msg) is Packed:
        return frame(msg.id, msg.payload, seq, system_id, component_id)
    # the class's id: some messages (RAW_IMU, STATUSTEXT) have a field called id
    return frame(type(msg).id, payload(msg), seq, system_id, component_id)


class Packed:
    """A message built by PackingCodec: its pymavlink class, pymavlink's encode method for it and
    the arguments it was called with, and its untrimmed payload."""

    __slots__ = ('cls', 'encoder', 'args', 'kwargs', 'payload')

    def __init__(self, cls, encoder, args, kwargs, body):
        self.cls, self.encoder, self.args, self.kwargs, self.payload = cls, encoder, args, kwargs, body

    @property
    def id(self):
        return self.cls.id

    def get_type(self):
        return self.cls.msgname

    def message(self):
        """The same message as a pymavlink object (to sign it, or to read its fields)."""
        return self.encoder(*self.args, **self.kwargs)

    def pack(self, mav):
        """pymavlink's pack(): the frame as `mav` numbers (and signs) it."""
        return self.message().pack(mav)


def _payload_function(cls, encoder):
    """payload(*args) for a message class: its fields in wire order, arrays element by element
    (char arrays whole, as bytes), in one struct call: what the class's generated pack() does,
    made from its field tables. Defaults are those of pymavlink's `encoder` method for it (they
    may differ from the class's constructor: heartbeat_encode's mavlink_version is 3)."""
    types = dict(zip(cls.fieldnames, cls.fieldtypes))
    items = []
    for name, length in zip(cls.ordered_fieldnames, cls.array_lengths):
        if length and types[name] != 'char':
            items.extend('%s[%d]' % (name, i) for i in range(length))
        else:
            items.append(name)
    defaults = {name: p.default for name, p in inspect.signature(encoder).parameters.items()
                if name in types and p.default is not inspect.Parameter.empty}
    params = ', '.join(name + ('=_defaults[%r]' % name if name in defaults else '') for name in cls.fieldnames)
    source = 'def payload(%s):\n    return _pack(%s)\n' % (params, ', '.join(items))
    namespace = {'_pack': cls.unpacker.pack, '_defaults': defaults}
    exec(compile(source, '<payload of %s>' % cls.msgname, 'exec'), namespace)
    return namespace['payload']


class PackingCodec:
    """pymavlink's `xxx_encode()` methods for messages that are only sent: each returns a Packed
    message. `srcSystem`/`srcComponent` are those of the codec it stands in for."""

    def __init__(self, mav):
        self._mav = mav
        self.srcSystem, self.srcComponent = mav.srcSystem, mav.srcComponent

    def __getattr__(self, name):
        cls = _CLASS_BY_ENCODER.get(name)
        if cls is None or name.startswith('_'):
            raise AttributeError(name)
        pymavlink_encode = getattr(self._mav, name)
        make_payload = _payload_function(cls, pymavlink_encode)

        def encode(*args, **kwargs):
            return Packed(cls, pymavlink_encode, args, kwargs, make_payload(*args, **kwargs))
        encode.__name__ = name
        setattr(self, name, encode)  # made once per codec and message type
        return encode


_CLASS_BY_ENCODER = {cls.msgname.lower() + '_encode': cls for cls in mavlink.mavlink_map.values()}
