"""The routing half of the UDP MAVLink link shared by the bridge and the simulated PX4, as mavros's router and
plugins sit on libmavconn: `MavlinkLink` is the endpoint both use, a router over one
offboard_py.mavlink_transport.UdpTransport (the socket, framing, CRC and signature checks, signing, sequence
loss, the counters, where to send), whose public names it keeps. It decides which datagrams are read (PX4's
partner rule drops what comes before the partner is known, offboard_py.link_remote) and whose frames move the
remote (with `peer`, only the peer's own; with signing on, only a signed one), which frames are decoded
(another system's never; a type only while one of its handlers needs it, `on(..., needed=)`, the rest are
CRC-checked and counted; a lone unsigned frame nobody decodes, most of PX4's stream, is skimmed without the
general walk), and hands each message to the handlers registered for its type, each frame to its raw hooks
(`on_raw`, `on_frames`) and each datagram as it came to a GCS (`on_datagram`): a plugin is a set of
handlers, not a branch in one long if/elif chain. Malformed bytes are counted and dropped, never raised. It
knows nothing of ROS or of the simulator; the caller owns the receive loop (`fileno()` for select,
`receive()` to drain the socket).
"""

import functools
import logging
import time

from offboard_py import wire
# the transport's names, importable from here too: the sim, the bridge and the tests import them so
from offboard_py.mavlink_transport import (  # noqa: F401
    BROADCAST_HOST, DEFAULT_BIND_HOST, DEFAULT_BIND_PORT, DEFAULT_REMOTE_PORT, MAVROS_MAX_DATAGRAM, MAX_DATAGRAM,
    MAX_PACKED_BYTES, SO_TIMESTAMPNS, STAMP_ANCILLARY_BYTES, TIMESPEC, UDP_SCHEMES, UdpTransport, UdpUrl, UrlError,
    kernel_stamp_ns, parse_udp_url)

# How long a handler's answer to needed() stands unless needs_changed() is called (the bridge calls it when
# a topic gains or loses a subscriber): what else a needed() reads may be this late
NEEDED_RECHECK_S = 0.05

log = logging.getLogger(__name__)


def _transport_attribute(name):
    """A MavlinkLink attribute that is its transport's, read and set there."""
    def get(self):
        return getattr(self.transport, name)

    def put(self, value):
        setattr(self.transport, name, value)
    on_class = getattr(UdpTransport, name, None)
    return property(get, put, doc=on_class.__doc__ if isinstance(on_class, property) else None)


def _transport_method(method):
    """A MavlinkLink method that is its transport's `method`: same name, arguments and docstring."""
    name = method.__name__

    @functools.wraps(method)
    def forward(self, *args, **kwargs):
        return getattr(self.transport, name)(*args, **kwargs)
    return forward


class _Walk:
    """What the frames of one datagram came to: `dispatch` is what to call, in the frames' order, as
    (callees, message or frame); the rest count frames, and say whether one was the peer's and signed."""

    __slots__ = ('dispatch', 'messages', 'undecoded', 'refused', 'foreign', 'from_peer', 'signed_in')

    def __init__(self, from_peer):
        self.dispatch = []
        self.messages = self.undecoded = self.refused = self.foreign = 0
        self.from_peer = from_peer  # a frame from the peer itself (from the start when anyone is the peer)
        self.signed_in = False      # a frame with a good signature


class MavlinkLink:
    """A MAVLink 2 UDP endpoint with handler dispatch and remote learning: the router over a UdpTransport."""

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
        self.peer = None if peer is None else (int(peer[0]), int(peer[1]))
        self.transport = UdpTransport(bind, remote, system_id, component_id, learn_remote, broadcast, name,
                                      lock_remote, clock, pack_datagrams)
        self.handlers = {}
        self._wanted_ids = set()  # the message ids some handler reads: only these are decoded ...
        self._always_ids = set()  # ... these always ...
        self._needed = {}         # ... and these (id -> [needed()]) while one of their handlers needs them
        self._raw_hooks = {}      # id -> [hook(frame)]: given the checked frame, decoded or not
        self._needs_cache = {}    # id (or 'frames') -> (needed, until when: time.monotonic())
        self.on_datagram = None  # optional raw hook: on_datagram(bytes) for each datagram with a valid frame
        self._frame_hook = None  # on_frames(): (hook, needed) for the raw frames
        self.last_receive_s = None

    # -- the transport's, on the link ---------------------------------------------------------

    sock = _transport_attribute('sock')
    bind = _transport_attribute('bind')
    name = _transport_attribute('name')
    mav = _transport_attribute('mav')
    stats = _transport_attribute('stats')
    signing = _transport_attribute('signing')
    remote_policy = _transport_attribute('remote_policy')
    pack_datagrams = _transport_attribute('pack_datagrams')
    arrival_ns = _transport_attribute('arrival_ns')
    system_id = _transport_attribute('system_id')
    remote = _transport_attribute('remote')
    partner_locked = _transport_attribute('partner_locked')
    stamp_arrivals = _transport_method(UdpTransport.stamp_arrivals)
    fileno = _transport_method(UdpTransport.fileno)
    close = _transport_method(UdpTransport.close)
    enable_signing = _transport_method(UdpTransport.enable_signing)
    disable_signing = _transport_method(UdpTransport.disable_signing)
    last_seq = _transport_method(UdpTransport.last_seq)
    _pack = _transport_method(UdpTransport._pack)
    send = _transport_method(UdpTransport.send)
    send_many = _transport_method(UdpTransport.send_many)
    send_bytes = _transport_method(UdpTransport.send_bytes)

    # -- handlers -----------------------------------------------------------------------------

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

    # -- receive ------------------------------------------------------------------------------

    def receive(self, max_datagrams=256):
        """Read up to max_datagrams pending datagrams and dispatch what they hold; how many were read
        (UdpTransport.receive, which asks poll() whether another is pending)."""
        return self.transport.receive(self.handle_datagram, max_datagrams)

    def handle_datagram(self, data, sender=None):
        """Take one datagram on its own: UDP carries whole frames, so a truncated frame at the
        end of one datagram must not swallow the frames of the next.

        Only the frames of message types a handler reads are decoded (wire.decode: pymavlink's
        decode); the others are CRC-checked and counted, as the MAVLink C
        library frames what it does not use. With signing on, every frame is decoded once
        its signature has been checked (offboard_py.signing: PX4's rules, not pymavlink's)."""
        self.transport.count_datagram(data)
        if not self._admit(sender):
            return
        signed = self.transport.signing.active
        if not signed and self._skim(data, sender):
            return
        self._deliver(data, sender, self._walk(data, signed))

    def _admit(self, sender):
        """Whether a datagram from sender is read at all: PX4 reads nothing until it knows its partner
        (before_partner). Under PX4's rule a datagram from another sender is read, but counted
        (other_senders): the replies still go to the partner."""
        policy = self.transport.remote_policy
        if not policy.admit(sender):
            self.transport.stats['before_partner'] += 1
            return False
        if policy.replies_stay_with_partner and sender is not None and sender != policy.address:
            self.transport.stats['other_senders'] += 1
        return True

    def _skim(self, data, sender):
        """PX4's and mavros's framing, one unsigned MAVLink 2 frame a datagram, of a type nobody decodes
        now (most of PX4's 400 a second: attitude, IMU, odometry nobody subscribes to): checked, counted and
        given to its raw hooks as handle_datagram's walk would, without the walk's lists and per-frame
        branches. False leaves the datagram to the walk (several frames, MAVLink 1, signed, another
        system's, a bad CRC, a type to decode)."""
        transport = self.transport
        msg_id = transport.lone_frame(data)
        if msg_id is None:
            return False
        peer = self.peer
        if peer is not None and data[5] != peer[0]:
            return False
        if msg_id in self._wanted_ids and self._needed_now(msg_id) or not transport.crc_ok(msg_id, data):
            return False
        source = (data[5], data[6])
        transport.count_sequence(source, data[4])
        frame_hook = self._frame_hook_now()
        if frame_hook is not None:
            self._call(frame_hook, data)
        self.last_receive_s = time.monotonic()
        if sender is not None and (peer is None or source == peer):
            transport.remote_policy.heard(sender)
        if self.on_datagram is not None:
            self.on_datagram(data)
        transport.stats['received'] += 1
        for hook in self._raw_hooks.get(msg_id, ()):
            self._call(hook, data)
        return True

    def _walk(self, data, signed):
        """The general way through a datagram: each frame with a right CRC (UdpTransport.frames), in its
        order, is routed. Another system's (with a peer) is counted and given to on_frames only, never
        decoded; the others are taken (_take, or _take_signed with signing on), their sequence numbers
        counted, and given to on_frames. Nothing is called but on_frames' hook: the rest is what the
        _Walk returned says to call."""
        transport, peer = self.transport, self.peer
        walk = _Walk(peer is None)
        frame_hook = self._frame_hook_now()
        take = self._take_signed if signed else self._take
        for msg_id, frame, source, seq in transport.frames(data):
            if peer is not None and source[0] != peer[0]:
                walk.foreign += 1  # still raw data for on_frames
                if frame_hook is not None:
                    self._call(frame_hook, frame)
                continue
            if not take(walk, msg_id, frame):
                continue
            walk.from_peer = walk.from_peer or source == peer
            transport.count_sequence(source, seq)  # what a sender's sequence numbers say was lost, per sender
            if frame_hook is not None:
                self._call(frame_hook, frame)
        return walk

    def _take(self, walk, msg_id, frame):
        """A checked frame, signing off: given to its raw hooks if it has any, and decoded for its handlers
        while one of them needs its type, else counted undecoded. False for one whose decode fails (hostile
        bytes: a string field that is not UTF-8, ...): counted, and given to nobody."""
        if msg_id not in self._wanted_ids:
            walk.undecoded += 1
            return True
        raw_hooks = self._raw_hooks.get(msg_id)
        if raw_hooks is not None:
            walk.dispatch.append((raw_hooks, frame))
        if not self._needed_now(msg_id):
            walk.undecoded += 1
            return True
        try:
            msg = wire.decode(msg_id, frame)
            msg = msg if msg is not None else self.transport.mav.decode(bytearray(frame))
        except Exception:  # pymavlink raises assorted errors on hostile bytes
            if raw_hooks is not None:
                walk.dispatch.pop()
            walk.refused += 1
            return False
        walk.messages += 1
        walk.dispatch.append((self.handlers.get(msg.get_type(), ()), msg))
        return True

    def _take_signed(self, walk, msg_id, frame):
        """A checked frame, signing on: let in or not by its signature (UdpTransport.check_signature), then
        decoded whatever its type, and given to its raw hooks and handlers. False for one refused or whose
        decode fails: counted, and given to nobody."""
        admitted, good_signature = self.transport.check_signature(msg_id, frame)
        if not admitted:
            walk.refused += 1
            return False
        try:
            msg = wire.decode_checked(frame)
        except Exception:  # pymavlink raises assorted errors on hostile bytes
            walk.refused += 1
            return False
        walk.signed_in = walk.signed_in or good_signature
        raw_hooks = self._raw_hooks.get(msg_id)
        if raw_hooks is not None:
            walk.dispatch.append((raw_hooks, frame))
        walk.messages += 1
        walk.dispatch.append((self.handlers.get(msg.get_type(), ()), msg))
        return True

    def _deliver(self, data, sender, walk):
        """What the walk of a datagram found: counted; then, if a frame was taken, the remote told of its
        sender, the datagram forwarded raw (on_datagram: to a GCS) and the hooks and handlers called in the
        frames' order. A datagram with only another system's frames is forwarded, but moves nothing."""
        stats = self.transport.stats
        if walk.refused:
            stats['bad_frames'] += walk.refused
        if walk.foreign:
            stats['other_system'] += walk.foreign
        if not walk.messages and not walk.undecoded:
            if walk.foreign and self.on_datagram is not None:
                self.on_datagram(data)
            return
        self.last_receive_s = time.monotonic()
        # with signing on, only a signed frame may move the learned remote (an unsigned RADIO_STATUS is let in,
        # not followed); before dispatch: under mavconn's rule replies go to whoever asked
        if sender is not None and walk.from_peer and (walk.signed_in or not self.transport.signing.active):
            self.transport.remote_policy.heard(sender)
        if self.on_datagram is not None:
            self.on_datagram(data)
        stats['received'] += walk.messages + walk.undecoded
        for callees, arg in walk.dispatch:
            for callee in callees:
                self._call(callee, arg)

    def _call(self, handler, msg):
        try:
            handler(msg)
        except Exception:  # a handler bug must not take the receive loop down
            self.transport.stats['handler_errors'] += 1
            log.exception('handler %r failed on %s', handler, msg.get_type() if hasattr(msg, 'get_type') else 'a frame')
