"""The transport half of a UDP MAVLink link, as libmavconn is mavros's: `UdpTransport` owns one UDP socket
(opened from mavconn's URL syntax, `parse_udp_url`) and the pymavlink codec that numbers and, with signing
on, signs what the link sends, one message a datagram as PX4 and mavros frame MAVLink over UDP (or packed,
`pack_datagrams`); it reads datagrams off the socket and hands each to its owner, cuts a datagram into frames
with their source and sequence number, checks each frame's CRC and, with signing on, its signature
(offboard_py.signing), counts what the senders' sequence numbers say was lost, and keeps where to send
(`remote`: its remote policy, offboard_py.link_remote). It keeps the link's counters (`stats`, one Counter
its router counts in too) and knows nothing of message types beyond the frame header: which frames are
read, decoded and given to whom, and whose datagrams move the remote, is its router's
(offboard_py.mavlink_link).
"""

import collections
import errno
import select
import socket
import struct
import sys
import threading
import time
from urllib.parse import urlsplit

from offboard_py import wire
from offboard_py.dialect import mavlink
from offboard_py.link_remote import MavconnRemote, Px4Partner
from offboard_py.signing import LinkSigning

# What the mavros URL leaves out: mavros binds 14555 and sends to 14550 by default.
DEFAULT_BIND_PORT = 14555
DEFAULT_REMOTE_PORT = 14550
# Unlike mavros (0.0.0.0), we listen on loopback unless a bind host is given.
DEFAULT_BIND_HOST = '127.0.0.1'
MAX_DATAGRAM = 65535
# What real mavros reads of one datagram (mavconn: MAVLINK_MAX_PACKET_LEN + 16): a longer one is cut,
# and the cut frame swallows the start of the next datagram
MAVROS_MAX_DATAGRAM = 296
# What one packed datagram may carry (pack_datagrams, not PX4's framing): within an Ethernet MTU
MAX_PACKED_BYTES = 1400

# Linux's SO_TIMESTAMPNS (and its control message, SCM_TIMESTAMPNS): the kernel's receive time of each
# datagram as a struct timespec (CLOCK_REALTIME). Python's socket module does not name it; 35 on every
# architecture but alpha, mips, parisc and sparc (asm-generic/socket.h).
SO_TIMESTAMPNS = 35
TIMESPEC = struct.Struct('@qq')
STAMP_ANCILLARY_BYTES = socket.CMSG_SPACE(TIMESPEC.size)


def kernel_stamp_ns(ancillary):
    """The SO_TIMESTAMPNS receive time (Unix ns) in recvmsg()'s ancillary data, or None."""
    for level, kind, value in ancillary:
        if level == socket.SOL_SOCKET and kind == SO_TIMESTAMPNS and len(value) >= TIMESPEC.size:
            seconds, nanoseconds = TIMESPEC.unpack_from(value)
            return seconds * 1000000000 + nanoseconds
    return None


class UrlError(ValueError):
    """An fcu_url/gcs_url this link cannot open; the message names the URL."""


# mavconn's UDP schemes: (broadcast until a remote talks, broadcast always)
UDP_SCHEMES = {'udp': (False, False), 'udp-b': (True, False), 'udp-pb': (True, True)}
BROADCAST_HOST = '255.255.255.255'


class UdpUrl(collections.namedtuple('UdpUrl', 'bind remote broadcast permanent')):
    """A parsed UDP URL: bind (host, port), remote (host, port) or None (learn it from the first
    packet), broadcast (send to BROADCAST_HOST), permanent (keep broadcasting: never learn)."""


def parse_udp_url(url, default_bind_port=DEFAULT_BIND_PORT, default_remote_port=DEFAULT_REMOTE_PORT):
    """mavconn's UDP URLs -> UdpUrl. Raises UrlError.

    - `udp://[bind_host][:port]@[remote_host][:port]`: a missing remote host means "learn
      it from the first packet"; missing ports are 14555 (bind) and 14550 (remote).
    - `udp-b://[bind_host][:port]@[:port]`: broadcast to the remote port until a remote
      talks, then answer it (mavconn's "udp-b").
    - `udp-pb://[bind_host][:port]@[:port]`: broadcast always ("permanent broadcast").
    """
    if not isinstance(url, str) or '://' not in url:
        raise UrlError('cannot read URL %r: expected udp://[bind_host][:port]@[remote_host][:port]' % (url,))
    scheme, rest = url.split('://', 1)
    if scheme not in UDP_SCHEMES:
        raise UrlError('URL %r: scheme %r is not supported (only %s)' % (url, scheme, ', '.join(
            s + '://' for s in UDP_SCHEMES)))
    broadcast, permanent = UDP_SCHEMES[scheme]
    rest = rest.split('/', 1)[0].split('?', 1)[0]
    bind_part, _, remote_part = rest.partition('@')

    def host_port(part, default_host, default_port, role):
        try:
            parsed = urlsplit('//' + part)
            port = parsed.port
        except ValueError as err:
            raise UrlError('URL %r: bad %s address %r (%s)' % (url, role, part, err))
        host = parsed.hostname or default_host
        return host, port if port is not None else default_port

    bind = host_port(bind_part, DEFAULT_BIND_HOST, default_bind_port, 'bind')
    if broadcast:
        host, port = host_port(remote_part, None, default_remote_port, 'remote')
        if host is not None:
            raise UrlError('URL %r: %s:// sends to the broadcast address; give only a port after @' % (url, scheme))
        remote = (BROADCAST_HOST, port)
    else:
        remote = host_port(remote_part, None, default_remote_port, 'remote') if remote_part else (None, None)
        remote = remote if remote[0] else None
    if bind[1] == 0:
        raise UrlError('URL %r: bind port 0 is not allowed' % url)
    return UdpUrl(bind, remote, broadcast, permanent)


# What a send may meet and the link bears, as UDP does: ECONNREFUSED (nobody listens there yet), a full
# buffer, no route for now. The datagram is lost and counted (send_errors); any other error is raised.
_SEND_ERRORS_BORNE = (errno.ECONNREFUSED, errno.EAGAIN, errno.ENOBUFS, errno.EHOSTUNREACH)


class _Sink:
    """pymavlink writes packed frames here; the link sends them itself."""

    def write(self, _data):
        pass


class UdpTransport:
    """One UDP socket carrying MAVLink frames: sending, reading, framing, checking, counting."""

    def __init__(self, bind, remote=None, system_id=1, component_id=1, learn_remote=True, broadcast=False,
                 name='udp', lock_remote=False, clock=time.monotonic, pack_datagrams=False):
        """Arguments as MavlinkLink's, less its router's `peer`: `remote` is where to send until one is
        learned (None: nowhere), `learn_remote` mavconn's rule and `lock_remote` PX4's instead, on `clock`
        (offboard_py.link_remote)."""
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        if broadcast:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
        try:
            self.sock.bind(bind)
        except OSError as err:
            self.sock.close()
            raise OSError(err.errno, 'cannot bind UDP %s:%d: %s' % (bind[0], bind[1], err.strerror))
        self.sock.setblocking(False)
        self._pending = select.poll()  # receive(): is another datagram waiting
        self._pending.register(self.sock.fileno(), select.POLLIN)
        self.bind = self.sock.getsockname()
        self.name = name  # for the log, as mavconn names its links (udp0, udp1)
        address = self._resolve(remote) if remote else None
        # where to send: PX4's partner rule or mavconn's (offboard_py.link_remote); the router tells it
        # which datagrams it admitted and whom it heard
        self.remote_policy = (Px4Partner(address, name, clock) if lock_remote
                              else MavconnRemote(address, name, learn=learn_remote))
        self.pack_datagrams = pack_datagrams
        self.mav = mavlink.MAVLink(_Sink(), srcSystem=system_id, srcComponent=component_id)
        self._send_lock = threading.Lock()  # pymavlink's sequence counter is not thread-safe
        # held from numbering a message to its sendto(): several threads send (the receive loop, ROS
        # callbacks, services), and frames must leave in their sequence's order, as mavconn's one
        # send queue keeps them, or the FCU counts the swaps as lost (LINK_NODE_STATUS.messages_lost)
        self._order_lock = threading.Lock()
        self.mav.robust_parsing = True
        self._last_seq = {}       # (system, component) -> the last sequence number received
        self.stats = collections.Counter()
        self.arrival_ns = None  # stamp_arrivals(): the kernel's receive time (Unix ns) of the datagram being handled
        self._ancillary = 0     # stamp_arrivals(): room for its control message
        self.signing = LinkSigning(self.mav, self._send_lock, self.stats)

    def stamp_arrivals(self):
        """Have the kernel stamp each datagram as it reaches the socket (SO_TIMESTAMPNS): while a datagram's
        handlers run, `arrival_ns` is that time (Unix ns), however late this process read it. For the
        benchmark, which times a stream as it reached the FCU and not when a busy simulator got to it; it
        costs a recvmsg per datagram. False where the kernel has no such option (then arrival_ns stays None)."""
        if not sys.platform.startswith('linux'):
            return False
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
        except OSError:
            return False
        self._ancillary = STAMP_ANCILLARY_BYTES
        return True

    @staticmethod
    def _resolve(address):
        host, port = address
        try:
            return socket.gethostbyname(host), int(port)
        except OSError as err:
            raise UrlError('cannot resolve host %r: %s' % (host, err))

    @property
    def system_id(self):
        return self.mav.srcSystem

    @property
    def remote(self):
        """Where this link sends now (None: nowhere yet)."""
        return self.remote_policy.address

    @property
    def partner_locked(self):
        return getattr(self.remote_policy, 'locked', False)

    def fileno(self):
        return self.sock.fileno()

    def close(self):
        self.sock.close()

    # -- signing ----------------------------------------------------------------------------

    def enable_signing(self, key, timestamp=0, required=True, link_id=0):
        """Sign what we send with `key`; if `required`, drop what is not signed with it."""
        self.signing.enable(key, timestamp, required, link_id)

    def disable_signing(self):
        self.signing.disable()

    # -- send -------------------------------------------------------------------------------

    def _pack(self, msg):
        """The frame of msg with this link's next sequence number (one counter per link, as
        PX4 and mavros keep one per channel)."""
        return self._pack_all((msg,))[0]

    def _pack_all(self, msgs):
        """The frames of msgs (pymavlink messages, or wire.Outgoing ones framed from their encoder's
        arguments), numbered in order by this link's codec (which signs them when signing is on)."""
        with self._send_lock:
            mav = self.mav
            seq = mav.seq
            frames = []
            for msg in msgs:
                signed = mav.signing.sign_outgoing
                if type(msg) is wire.Outgoing:
                    if not signed:
                        frames.append(msg.frame(seq, mav.srcSystem, mav.srcComponent))
                        seq = (seq + 1) & 0xFF
                        continue
                    msg = msg.message()  # pymavlink signs its own messages
                if signed:
                    self.signing.stamp_outgoing()
                mav.seq = seq  # pymavlink's pack() numbers the frame with it and leaves it as it was
                frames.append(msg.pack(mav))
                seq = (seq + 1) & 0xFF
            mav.seq = seq
            self.stats['messages_sent'] += len(frames)
            return frames

    def send(self, msg):
        """Pack and send a pymavlink message; False when no remote is known yet."""
        if self.remote is None:
            return False
        with self._order_lock:
            return self.send_bytes(self._pack(msg))

    def send_many(self, msgs):
        """Send msgs in order, each in a datagram of its own, as PX4 and mavros frame MAVLink over UDP
        (send_start/send_finish per message): mavconn reads at most MAVROS_MAX_DATAGRAM bytes of a
        datagram. With pack_datagrams (an option for measurements, not PX4's framing) as many frames
        as fit in MAX_PACKED_BYTES share a datagram. False when no remote is known yet."""
        if self.remote is None:
            return False
        with self._order_lock:
            return self._send_frames(self._pack_all(msgs))

    def _send_frames(self, frames):
        if not self.pack_datagrams:  # a datagram each, counted once for all (the simulator's 765 a second)
            remote, sendto, stats = self.remote, self.sock.sendto, self.stats
            sent = size = 0
            try:
                for frame in frames:
                    try:
                        sendto(frame, remote)
                    except OSError as err:
                        stats['send_errors'] += 1
                        if err.errno not in _SEND_ERRORS_BORNE:
                            raise
                        continue
                    sent += 1
                    size += len(frame)
            finally:
                stats['sent'] += sent
                stats['bytes_sent'] += size
            return sent == len(frames)
        batch, size = [], 0
        for frame in frames:
            if batch and size + len(frame) > MAX_PACKED_BYTES:
                self.send_bytes(b''.join(batch))
                batch, size = [], 0
            batch.append(frame)
            size += len(frame)
        return self.send_bytes(b''.join(batch)) if batch else True

    def send_bytes(self, data):
        if self.remote is None:
            return False
        try:
            self.sock.sendto(data, self.remote)
        except OSError as err:
            self.stats['send_errors'] += 1
            if err.errno not in _SEND_ERRORS_BORNE:
                raise
            return False
        self.stats['sent'] += 1
        self.stats['bytes_sent'] += len(data)
        return True

    # -- receive ----------------------------------------------------------------------------

    def receive(self, handle, max_datagrams=256):
        """Read up to max_datagrams pending datagrams, handing each to handle(data, sender) (the router's
        handle_datagram); how many were read. Whether another is pending is asked of poll(), not of a read
        that fails: the EAGAIN a drained socket raises is an OSError whose message CPython formats each
        time, which cost more than handling a datagram at PX4's 400 datagrams a second (2026-11-25, perf on
        the replay bench)."""
        count = 0
        pending = self._pending.poll
        for _ in range(max_datagrams):
            try:
                if self._ancillary:
                    data, sender = self._receive_stamped()
                else:
                    data, sender = self.sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                break
            except ConnectionRefusedError:
                continue  # an ICMP error for an earlier send, not a datagram
            count += 1
            handle(data, sender)
            if not pending(0):
                break
        return count

    def _receive_stamped(self):
        data, ancillary, _flags, sender = self.sock.recvmsg(MAX_DATAGRAM, self._ancillary)
        self.arrival_ns = kernel_stamp_ns(ancillary)
        return data, sender

    def count_datagram(self, data):
        """A datagram came in (fed by receive() or by hand): counted, whatever it holds."""
        self.stats['datagrams'] += 1
        self.stats['bytes_received'] += len(data)

    def frames(self, data):
        """The frames of one datagram with a right CRC, in order, as (msg_id, frame, source, seq): source
        is the header's (system, component), seq its sequence number. UDP carries whole frames, so a
        truncated frame at the end of a datagram never swallows the frames of the next. What is no frame
        or fails its CRC is skipped, and counted (bad_frames) once the datagram is walked to its end."""
        bad = 0
        crc_ok = wire.crc_ok
        for msg_id, frame in wire.split(data):
            if msg_id is None or not crc_ok(msg_id, frame):
                bad += 1
            elif frame[0] == wire.MAGIC_V2:
                yield msg_id, frame, (frame[5], frame[6]), frame[4]
            else:
                yield msg_id, frame, (frame[3], frame[4]), frame[2]
        if bad:
            self.stats['bad_frames'] += bad

    @staticmethod
    def lone_frame(data):
        """The message id of a datagram that is one unsigned MAVLink 2 frame and nothing else (PX4's and
        mavros's framing, most datagrams), else None. Its CRC is not checked yet (crc_ok)."""
        size = len(data)
        if size < wire.HEADER_V2 + 2 or data[0] != wire.MAGIC_V2 or data[2] or size != wire.HEADER_V2 + 2 + data[1]:
            return None
        return data[7] | data[8] << 8 | data[9] << 16

    crc_ok = staticmethod(wire.crc_ok)  # whether a frame carries the right CRC for its message id

    def check_signature(self, msg_id, frame):
        """With signing on, whether a frame with a right CRC is let in by PX4's rules (offboard_py.signing,
        which counts what it refuses and why), and whether it carried a good signature: (admitted, signed)."""
        return self.signing.admit(frame, msg_id)

    def count_sequence(self, source, seq):
        """A frame from source (system, component) with sequence number seq was taken: what the gap since
        the last one from there says was lost is counted (dropped)."""
        last = self._last_seq.get(source)
        if last is not None:
            lost = (seq - last - 1) & 0xFF
            if lost:
                self.stats['dropped'] += lost
        self._last_seq[source] = seq

    def last_seq(self, source):
        """The sequence number of the last frame from (system, component), 0 before any."""
        return self._last_seq.get(source, 0)
