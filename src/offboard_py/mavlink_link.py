"""One MAVLink 2 endpoint over UDP: the link layer shared by the bridge and the simulated PX4.

- `parse_udp_url()` reads mavros's URL syntax `udp://[bind_host][:port]@[remote_host][:port]`.
- `MavlinkLink` owns a UDP socket and a pymavlink codec; where it sends is its remote policy's
  (offboard_py.link_remote: mavros's rule, every sender of a valid frame from the peer becomes the
  remote, or PX4's, `lock_remote`: the first datagram's sender for good). It sends one message a
  datagram, as PX4 and mavros do, and parses every datagram and hands each message to the handlers registered for its type: a
  plugin is a set of handlers, not a branch in one long if/elif chain. A type is decoded only
  while one of its handlers needs it (`on(..., needed=)`); the rest are CRC-checked and
  counted. Malformed bytes are counted and dropped, never raised.
- `enable_signing()` turns on MAVLink 2 signing (offboard_py.signing does the work).

It knows nothing of ROS or of the simulator; the caller owns the receive loop
(`fileno()` for select, `receive()` to drain the socket).
"""

import collections
import errno
import logging
import select
import socket
import struct
import sys
import threading
import time
from urllib.parse import urlsplit

from offboard_py import wire
from offboard_py.link_remote import MavconnRemote, Px4Partner
from offboard_py.dialect import mavlink
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
# How long a handler's answer to needed() stands unless needs_changed() is called (the bridge calls it when
# a topic gains or loses a subscriber): what else a needed() reads may be this late
NEEDED_RECHECK_S = 0.05
# PX4's UDP link (mavlink_receiver.cpp): with a default partner not on this host, the partner is
# taken from the first datagram after this long since the link started (seconds of its clock)

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


log = logging.getLogger(__name__)


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


class MavlinkLink:
    """A MAVLink 2 UDP endpoint with handler dispatch and remote learning."""

    def __init__(self, bind, remote=None, system_id=1, component_id=1, learn_remote=True, broadcast=False,
                 name='udp', lock_remote=False, clock=time.monotonic, peer=None, pack_datagrams=False):
        """`pack_datagrams`: send_many() packs several frames into one datagram (not PX4's or mavros's
        framing, which is one message a datagram; real mavros cannot read a packed datagram over 296
        bytes). `remote`: where to send until one is learned (None: nowhere). `learn_remote`: follow every
        sender of a valid frame (mavros). `lock_remote`: PX4's rule instead (offboard_py.link_remote), on
        `clock` (seconds). `peer`: (system id, component id) of what the remote is (None: anyone; the
        bridge's FCU link: its target system and component). A frame from another system is then
        CRC-checked and counted (`other_system`) but not decoded, so junk from other systems is dropped
        before a full parse, and only a datagram with a valid frame from the peer itself moves the
        remote: a flood from another port cannot divert the link."""
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
        self.peer = None if peer is None else (int(peer[0]), int(peer[1]))
        address = self._resolve(remote) if remote else None
        # where to send: PX4's partner rule or mavconn's (offboard_py.link_remote)
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
        self.handlers = {}
        self._wanted_ids = set()  # the message ids some handler reads: only these are decoded ...
        self._always_ids = set()  # ... these always ...
        self._needed = {}         # ... and these (id -> [needed()]) while one of their handlers needs them
        self._raw_hooks = {}      # id -> [hook(frame)]: given the checked frame, decoded or not
        self._needs_cache = {}    # id (or 'frames') -> (needed, until when: time.monotonic())
        self._last_seq = {}       # (system, component) -> the last sequence number received
        self.on_datagram = None  # optional raw hook: on_datagram(bytes) for each datagram with a valid frame
        self._frame_hook = None  # on_frames(): (hook, needed) for the raw frames
        self.stats = collections.Counter()
        self.last_receive_s = None
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

    def last_seq(self, source):
        """The sequence number of the last frame from (system, component), 0 before any."""
        return self._last_seq.get(source, 0)

    def fileno(self):
        return self.sock.fileno()

    def on(self, msg_type, handler, needed=None):
        """Call handler(msg) for every message of type `msg_type` (e.g. 'HEARTBEAT'). `needed`:
        None (always), or a function that says whether the handler has anything to do now (a
        bridge plugin: whether its topics have subscribers). While no handler of a type needs it,
        its frames are not decoded, only CRC-checked and counted: decoding is most of what a
        frame costs, and nothing else reads it."""
        msg_id = wire.msg_id(msg_type)
        self.handlers.setdefault(msg_type, []).append(handler)
        self._wanted_ids.add(msg_id)
        if needed is None:
            self._always_ids.add(msg_id)
        else:
            self._needed.setdefault(msg_id, []).append(needed)
        self._needs_cache.pop(msg_id, None)

    def on_raw(self, msg_type, hook):
        """Call hook(frame bytes) for every valid frame of type `msg_type`, decoded or not, in its turn
        among the handlers: for a reader that keeps the latest and decodes it only when it is asked
        (wire.decode_checked), as most of PX4's 50 Hz attitude and IMU messages are read by nobody."""
        msg_id = wire.msg_id(msg_type)
        self._raw_hooks.setdefault(msg_id, []).append(hook)
        self._wanted_ids.add(msg_id)

    def on_frames(self, hook, needed=None):
        """Call hook(frame bytes) for each valid frame, read or not, while `needed()` says so
        (None: always; asked as on()'s needed() is asked), as on() does for messages."""
        self._frame_hook = (hook, needed)
        self._needs_cache.pop('frames', None)

    def _needed_now(self, msg_id):
        """Whether a frame of this wanted type is to be decoded now: the handlers' needed() asked at
        most once every NEEDED_RECHECK_S per type, or after needs_changed() (asking at every frame of
        PX4's 50 Hz streams cost a fifth of what a skipped frame costs)."""
        if msg_id in self._always_ids:
            return True
        return self._recheck(msg_id, self._needed.get(msg_id, ()))

    def needs_changed(self):
        """What a handler's needed() reads has moved (a topic gained or lost a subscriber): ask them
        again at the next frame, not NEEDED_RECHECK_S later."""
        self._needs_cache.clear()

    def _frame_hook_now(self):
        """on_frames()'s hook while its needed() says so (asked as _needed_now asks), else None."""
        if self._frame_hook is None:
            return None
        hook, needed = self._frame_hook
        return hook if needed is None or self._recheck('frames', (needed,)) else None

    def _recheck(self, key, needs):
        now = time.monotonic()
        cached = self._needs_cache.get(key)
        if cached is None or now >= cached[1]:
            cached = self._needs_cache[key] = (any(needed() for needed in needs), now + NEEDED_RECHECK_S)
        return cached[0]

    # -- signing ----------------------------------------------------------------------------

    def enable_signing(self, key, timestamp=0, required=True, link_id=0):
        """Sign what we send with `key`; if `required`, drop what is not signed with it."""
        self.signing.enable(key, timestamp, required, link_id)

    def disable_signing(self):
        self.signing.disable()

    # -- send and receive -------------------------------------------------------------------

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

    def receive(self, max_datagrams=256):
        """Read up to max_datagrams pending datagrams and dispatch what they hold; how many were read.
        Whether another is pending is asked of poll(), not of a read that fails: the EAGAIN a drained
        socket raises is an OSError whose message CPython formats each time, which cost more than
        handling a datagram at PX4's 400 datagrams a second (2026-11-25, perf on the replay bench)."""
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
            self.handle_datagram(data, sender)
            if not pending(0):
                break
        return count

    def _receive_stamped(self):
        data, ancillary, _flags, sender = self.sock.recvmsg(MAX_DATAGRAM, self._ancillary)
        self.arrival_ns = kernel_stamp_ns(ancillary)
        return data, sender

    def handle_datagram(self, data, sender=None):
        """Take one datagram on its own: UDP carries whole frames, so a truncated frame at the
        end of one datagram must not swallow the frames of the next.

        Only the frames of message types a handler reads are decoded (wire.decode: pymavlink's
        decode); the others are CRC-checked and counted, as the MAVLink C
        library frames what it does not use. With signing on, every frame is decoded once
        its signature has been checked (offboard_py.signing: PX4's rules, not pymavlink's)."""
        self.stats['datagrams'] += 1
        self.stats['bytes_received'] += len(data)
        policy = self.remote_policy
        if not policy.admit(sender):
            self.stats['before_partner'] += 1
            return  # PX4 reads nothing until it knows its partner
        if policy.replies_stay_with_partner and sender is not None and sender != policy.address:
            self.stats['other_senders'] += 1  # read, but the replies still go to the partner
        decode_all = self.signing.active
        if not decode_all and self._skim(data, sender):
            return
        wanted = self._wanted_ids
        peer = self.peer
        frame_hook = self._frame_hook_now()
        last_seq = self._last_seq
        raw_hooks = self._raw_hooks
        handlers = self.handlers
        # what to call, in the frames' order: (handlers, message) or (raw hooks, frame)
        messages, dispatch, undecoded, bad, foreign, dropped, from_peer = [], [], 0, 0, 0, 0, peer is None
        signed_in = False  # a frame with a good signature came in this datagram
        for msg_id, frame in wire.split(data):
            if msg_id is None:
                bad += 1
                continue
            v2 = frame[0] == wire.MAGIC_V2
            source = (frame[5], frame[6]) if v2 else (frame[3], frame[4])
            if peer is not None and source[0] != peer[0]:
                # another system's frame: checked (a valid one is still raw data for on_frames), never decoded
                if wire.crc_ok(msg_id, frame):
                    foreign += 1
                    if frame_hook is not None:
                        self._call(frame_hook, frame)
                else:
                    bad += 1
                continue
            if decode_all:
                if not wire.crc_ok(msg_id, frame):
                    bad += 1
                    continue
                admitted, good_signature = self.signing.admit(frame, msg_id)
                if not admitted:
                    bad += 1
                    continue
                try:
                    msg = wire.decode_checked(frame)
                except Exception:  # pymavlink raises assorted errors on hostile bytes
                    bad += 1
                    continue
                signed_in = signed_in or good_signature
                if msg_id in raw_hooks:
                    dispatch.append((raw_hooks[msg_id], frame))
                messages.append(msg)
                dispatch.append((handlers.get(msg.get_type(), ()), msg))
            elif not wire.crc_ok(msg_id, frame):
                bad += 1
                continue
            elif msg_id not in wanted:
                undecoded += 1
            else:
                if msg_id in raw_hooks:
                    dispatch.append((raw_hooks[msg_id], frame))
                if not self._needed_now(msg_id):
                    undecoded += 1
                else:
                    try:
                        msg = wire.decode(msg_id, frame)
                        msg = msg if msg is not None else self.mav.decode(bytearray(frame))
                    except Exception:  # hostile bytes: a string field that is not UTF-8, ...
                        if msg_id in raw_hooks:
                            dispatch.pop()
                        bad += 1
                        continue
                    messages.append(msg)
                    dispatch.append((handlers.get(msg.get_type(), ()), msg))
            from_peer = from_peer or source == peer
            # frames a sender's sequence numbers say were lost, per sender
            seq = frame[4] if v2 else frame[2]
            last = last_seq.get(source)
            if last is not None:
                dropped += (seq - last - 1) & 0xFF
            last_seq[source] = seq
            if frame_hook is not None:
                self._call(frame_hook, frame)
        if dropped:
            self.stats['dropped'] += dropped
        if bad:
            self.stats['bad_frames'] += bad
        if foreign:
            self.stats['other_system'] += foreign
        if not messages and not undecoded:
            if foreign and self.on_datagram is not None:
                self.on_datagram(data)  # passed on raw (to a GCS) as before, but it moves nothing
            return
        self.last_receive_s = time.monotonic()
        # with signing on, only a signed frame may move the learned remote (an unsigned RADIO_STATUS is let in,
        # not followed)
        if sender is not None and from_peer and (signed_in or not self.signing.active):
            policy.heard(sender)  # before dispatch: under mavconn's rule replies go to whoever asked
        if self.on_datagram is not None:
            self.on_datagram(data)
        self.stats['received'] += len(messages) + undecoded
        for callees, arg in dispatch:
            for callee in callees:
                self._call(callee, arg)

    def _skim(self, data, sender):
        """PX4's and mavros's framing, one unsigned MAVLink 2 frame a datagram, of a type nobody decodes
        now (most of PX4's 400 a second: attitude, IMU, odometry nobody subscribes to): checked, counted and
        given to its raw hooks as handle_datagram's walk would, without the walk's lists and per-frame
        branches. False leaves the datagram to the walk (several frames, MAVLink 1, signed, another
        system's, a bad CRC, a type to decode)."""
        size = len(data)
        if size < wire.HEADER_V2 + 2 or data[0] != wire.MAGIC_V2 or data[2] or size != wire.HEADER_V2 + 2 + data[1]:
            return False
        peer = self.peer
        if peer is not None and data[5] != peer[0]:
            return False
        msg_id = data[7] | data[8] << 8 | data[9] << 16
        if msg_id in self._wanted_ids and self._needed_now(msg_id) or not wire.crc_ok(msg_id, data):
            return False
        source = (data[5], data[6])
        last = self._last_seq.get(source)
        if last is not None and (data[4] - last - 1) & 0xFF:
            self.stats['dropped'] += (data[4] - last - 1) & 0xFF
        self._last_seq[source] = data[4]
        frame_hook = self._frame_hook_now()
        if frame_hook is not None:
            self._call(frame_hook, data)
        self.last_receive_s = time.monotonic()
        if sender is not None and (peer is None or source == peer):
            self.remote_policy.heard(sender)
        if self.on_datagram is not None:
            self.on_datagram(data)
        self.stats['received'] += 1
        for hook in self._raw_hooks.get(msg_id, ()):
            self._call(hook, data)
        return True

    @property
    def remote(self):
        """Where this link sends now (None: nowhere yet)."""
        return self.remote_policy.address

    @property
    def partner_locked(self):
        return getattr(self.remote_policy, 'locked', False)

    def _call(self, handler, msg):
        try:
            handler(msg)
        except Exception:  # a handler bug must not take the receive loop down
            self.stats['handler_errors'] += 1
            log.exception('handler %r failed on %s', handler, msg.get_type() if hasattr(msg, 'get_type') else 'a frame')

    def close(self):
        self.sock.close()
