"""Reading a recording of the FCU link into messages, in time order.

Two forms, both as reference/conversations/README.md describes them:
- a pcap (libpcap format, microsecond or nanosecond stamps, optionally xz-compressed) of UDP
  datagrams on Ethernet/IPv4 (or raw IPv4): the FCU's side is the datagrams from its port
  (14580, PX4 SITL instance 0's onboard port), the ROS side's those to it; each datagram's
  MAVLink frames are decoded with the project's dialect (offboard_py.dialect), so ids 8, 300
  and 380 decode; an id the dialect does not know is kept as UNKNOWN_<id>;
- a decoded JSONL (optionally .xz): one message a line with t, dir (fcu | ros), sys, comp,
  seq, id, type and the fields.
Times are seconds since the recording's first datagram. Only the standard library and the
dialect: no ROS.
"""

import collections
import json
import lzma
import struct

from offboard_py.dialect import mavlink

FCU_PORT = 14580   # the FCU's onboard UDP port (PX4 SITL instance 0), as in the references
DIRECTIONS = ('fcu', 'ros')  # fcu: sent by the FCU; ros: sent to it by the ROS side (mavros or our bridge)

PCAP_MAGIC = {0xa1b2c3d4: 1e-6, 0xa1b23c4d: 1e-9}  # stamp fraction: microseconds or nanoseconds
LINKTYPE_ETHERNET, LINKTYPE_RAW, LINKTYPE_IPV4 = 1, 101, 228
ETHERTYPE_IPV4 = 0x0800
IPPROTO_UDP = 17


class RecordingError(ValueError):
    """A recording that cannot be read; the message names the file and what is wrong."""


class Message(collections.namedtuple('Message', 't dir sys comp seq id type fields')):
    """One MAVLink message of a recording: t (s since the first datagram), dir ('fcu' or 'ros'),
    sender's sys and comp, its seq, message id, type name, and its fields (a dict)."""

    def get(self, name, default=None):
        return self.fields.get(name, default)


def _open(path):
    with open(path, 'rb') as f:
        head = f.read(6)
    if head == b'\xfd7zXZ\x00':
        return lzma.open(path, 'rb')
    return open(path, 'rb')


def read(path, fcu_port=FCU_PORT):
    """The messages of a recording file (pcap or JSONL, either optionally xz-compressed), by time."""
    name = str(path)
    stem = name[:-3] if name.endswith('.xz') else name
    try:
        with _open(name) as f:
            if stem.endswith('.jsonl') or stem.endswith('.json'):
                return read_jsonl(f, name)
            return read_pcap(f, name, fcu_port)
    except OSError as err:
        raise RecordingError('%s: cannot read: %s' % (name, err))
    except lzma.LZMAError as err:
        raise RecordingError('%s: broken xz data: %s' % (name, err))


HEAD = ('t', 'dir', 'sys', 'comp', 'seq', 'id', 'type')


def to_record(m, fields=None):
    """A message as one JSONL record (a dict): its head, then its fields (those named, or all). A field
    named like a head key (HEARTBEAT's and MISSION_ACK's 'type') is written with a 'field_' prefix."""
    record = {'t': m.t, 'dir': m.dir, 'sys': m.sys, 'comp': m.comp, 'seq': m.seq, 'id': m.id, 'type': m.type}
    for name in (m.fields if fields is None else fields):
        if name in m.fields:
            record[('field_' + name) if name in HEAD else name] = m.fields[name]
    return record


def read_jsonl(lines, name='<jsonl>'):
    """Messages from decoded JSONL lines (bytes or str): t, dir, sys, comp, seq, id, type + fields
    (to_record's form; a 'field_' prefix is taken off)."""
    out = []
    for number, line in enumerate(lines, 1):
        if isinstance(line, bytes):
            line = line.decode('utf-8', 'replace')
        line = line.strip()
        if not line:
            continue
        try:
            d = json.loads(line)
            fields = {(k[len('field_'):] if k.startswith('field_') else k): v for k, v in d.items()
                      if k not in HEAD and k not in ('sport', 'dport')}
            m = Message(float(d['t']), d['dir'], int(d['sys']), int(d['comp']), int(d['seq']), int(d['id']),
                        str(d['type']), fields)
        except (ValueError, KeyError, TypeError) as err:
            raise RecordingError('%s line %d: not a decoded message (%s: %s)' % (name, number, type(err).__name__, err))
        if m.dir not in DIRECTIONS:
            raise RecordingError('%s line %d: dir %r is neither fcu nor ros' % (name, number, m.dir))
        out.append(m)
    out.sort(key=lambda m: m.t)
    return out


def udp_datagrams(f, name='<pcap>'):
    """(time s, sport, dport, payload) of each UDP/IPv4 datagram of a pcap file object."""
    head = f.read(24)
    if len(head) < 24:
        raise RecordingError('%s: too short for a pcap header (%d bytes)' % (name, len(head)))
    for endian in ('<', '>'):
        magic, _major, _minor, _zone, _sigfigs, _snaplen, linktype = struct.unpack(endian + 'IHHiIII', head)
        if magic in PCAP_MAGIC:
            break
    else:
        raise RecordingError('%s: not a pcap file (magic %s); pcapng is not read, convert it with editcap -F pcap'
                             % (name, head[:4].hex()))
    fraction = PCAP_MAGIC[magic]
    if linktype not in (LINKTYPE_ETHERNET, LINKTYPE_RAW, LINKTYPE_IPV4):
        raise RecordingError('%s: link type %d is not Ethernet or raw IPv4' % (name, linktype))
    record = struct.Struct(endian + 'IIII')
    while True:
        rec = f.read(16)
        if not rec:
            return
        if len(rec) < 16:
            raise RecordingError('%s: cut short in a record header' % name)
        sec, frac, caplen, _origlen = record.unpack(rec)
        frame = f.read(caplen)
        if len(frame) < caplen:
            raise RecordingError('%s: cut short in a packet (%d of %d bytes)' % (name, len(frame), caplen))
        ip = frame
        if linktype == LINKTYPE_ETHERNET:
            if len(frame) < 14 or struct.unpack('!H', frame[12:14])[0] != ETHERTYPE_IPV4:
                continue
            ip = frame[14:]
        if len(ip) < 20 or ip[0] >> 4 != 4 or ip[9] != IPPROTO_UDP:
            continue
        ihl = (ip[0] & 0x0f) * 4
        total = struct.unpack('!H', ip[2:4])[0]
        udp = ip[ihl:total]
        if len(udp) < 8:
            continue
        sport, dport, length = struct.unpack('!HHH', udp[:6])
        yield sec + frac * fraction, sport, dport, bytes(udp[8:length])


def _fields(msg):
    out = {}
    for name in msg.get_fieldnames():
        value = getattr(msg, name)
        if isinstance(value, (bytes, bytearray)):
            value = value.hex()
        elif isinstance(value, float) and value != value:
            value = None  # NaN, as the references' JSONL writes it
        out[name] = value
    return out


def frame_header(frame):
    """(seq, sys, comp, msg id) from a MAVLink 2 (0xFD) or 1 (0xFE) frame's header."""
    if frame[:1] == b'\xfd' and len(frame) >= 10:
        return frame[4], frame[5], frame[6], frame[7] | frame[8] << 8 | frame[9] << 16
    if frame[:1] == b'\xfe' and len(frame) >= 6:
        return frame[2], frame[3], frame[4], frame[5]
    raise RecordingError('not a MAVLink frame: %s' % frame[:10].hex())


def read_pcap(f, name='<pcap>', fcu_port=FCU_PORT):
    """Messages from a pcap file object: from fcu_port 'fcu', to it 'ros'; other datagrams are skipped.
    Each direction has its own parser (a frame never spans two senders' datagrams)."""
    parsers = {}
    out = []
    start = None
    for stamp, sport, dport, payload in udp_datagrams(f, name):
        if sport == fcu_port:
            direction = 'fcu'
        elif dport == fcu_port:
            direction = 'ros'
        else:
            continue
        if start is None:
            start = stamp
        parser = parsers.get(direction)
        if parser is None:
            parser = parsers[direction] = mavlink.MAVLink(None)
            parser.robust_parsing = True
        for msg in parser.parse_buffer(payload) or ():
            kind = msg.get_type()
            if kind == 'BAD_DATA':
                continue
            if kind.startswith('UNKNOWN_'):
                # pymavlink gives an unknown message no header: read it from the frame itself
                sender_seq, sys_id, comp_id, msg_id = frame_header(bytes(msg.get_msgbuf()))
                fields = {}
            else:
                header = msg.get_header()
                sender_seq, sys_id, comp_id, msg_id = header.seq, header.srcSystem, header.srcComponent, \
                    msg.get_msgId()
                fields = _fields(msg)
            out.append(Message(round(stamp - start, 6), direction, sys_id, comp_id, sender_seq, msg_id, kind, fields))
    return out

