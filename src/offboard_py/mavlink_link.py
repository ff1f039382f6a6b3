"""One MAVLink 2 endpoint over UDP: the link layer shared by the bridge and the simulated PX4.

- `parse_udp_url()` reads mavros's URL syntax `udp://[bind_host][:port]@[remote_host][:port]`.
- `MavlinkLink` owns a UDP socket and a pymavlink codec. It learns its remote from the
  packets it receives, as mavros's UDP link and PX4's do (so a client bound on 14540
  answers PX4 wherever PX4 sends from), parses every datagram, and hands each message
  to the handlers registered for its type: a plugin is a set of handlers, not a branch
  in one long if/elif chain. Malformed bytes are counted and dropped, never raised.

- `enable_signing()` turns on MAVLink 2 message signing: every frame we send is signed,
  and when signing is required a received frame without a valid signature is dropped and
  counted (`stats['unsigned_rejected']`, `stats['bad_signature']`), except the few
  messages PX4 always takes unsigned. The key file is PX4's: 32 key bytes, optionally
  followed by the 64-bit little-endian timestamp.

It knows nothing of ROS or of the simulator; the caller owns the receive loop
(`fileno()` for select, `receive()` to drain the socket).
"""

import collections
import errno
import hashlib
import hmac
import logging
import os
import struct
import socket
import threading
import time
from urllib.parse import urlsplit

from pymavlink.dialects.v20 import development as mavlink

# What the mavros URL leaves out: mavros binds 14555 and sends to 14550 by default.
DEFAULT_BIND_PORT = 14555
DEFAULT_REMOTE_PORT = 14550
# Unlike mavros (0.0.0.0), we listen on loopback unless a bind host is given.
DEFAULT_BIND_HOST = '127.0.0.1'
MAX_DATAGRAM = 65535

# MAVLink signing: timestamps count 10 us units since 2015-01-01 00:00:00 UTC.
SIGNING_EPOCH_UNIX_S = 1420070400
SIGNING_KEY_LENGTH = 32
# A new stream is accepted only if its timestamp is at most one minute behind ours.
SIGNING_NEW_STREAM_WINDOW = 60 * 100000
# What PX4 accepts unsigned even when signing is required (mavlink_sign_control.cpp).
ALWAYS_ACCEPTED_UNSIGNED = frozenset((mavlink.MAVLINK_MSG_ID_RADIO_STATUS, mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE,
                                      mavlink.MAVLINK_MSG_ID_COLLISION))

log = logging.getLogger(__name__)


class SigningKeyError(ValueError):
    """A signing key file that cannot be used; the message names the file."""


def signing_timestamp_now():
    return max(0, int((time.time() - SIGNING_EPOCH_UNIX_S) * 100000))


def read_signing_key(path):
    """PX4's key file (32 key bytes, then an optional uint64 LE timestamp) -> (key, timestamp)."""
    try:
        with open(path, 'rb') as f:
            data = f.read(SIGNING_KEY_LENGTH + 9)
    except OSError as err:
        raise SigningKeyError('signing key file %s: %s' % (path, err.strerror or err))
    if len(data) not in (SIGNING_KEY_LENGTH, SIGNING_KEY_LENGTH + 8):
        raise SigningKeyError('signing key file %s: %d bytes; expected a 32-byte key, optionally followed by an '
                              '8-byte timestamp (as PX4 stores it)' % (path, len(data)))
    key = data[:SIGNING_KEY_LENGTH]
    timestamp = struct.unpack('<Q', data[SIGNING_KEY_LENGTH:])[0] if len(data) > SIGNING_KEY_LENGTH else 0
    if not any(key):
        raise SigningKeyError('signing key file %s: the key is all zeros, which means "no key" in MAVLink' % path)
    return key, timestamp


def write_signing_key(path, key, timestamp=0):
    """Write a key file in PX4's format, readable by its owner only."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, 'wb') as f:
        f.write(bytes(key) + struct.pack('<Q', timestamp))


class UrlError(ValueError):
    """An fcu_url/gcs_url this link cannot open; the message names the URL."""


def parse_udp_url(url, default_bind_port=DEFAULT_BIND_PORT, default_remote_port=DEFAULT_REMOTE_PORT):
    """`udp://[bind_host][:port]@[remote_host][:port]` -> ((bind_host, port), (remote_host, port) or None).

    A missing remote host means "learn it from the first packet". Raises UrlError.
    """
    if not isinstance(url, str) or '://' not in url:
        raise UrlError('cannot read URL %r: expected udp://[bind_host][:port]@[remote_host][:port]' % (url,))
    scheme, rest = url.split('://', 1)
    if scheme != 'udp':
        raise UrlError('URL %r: scheme %r is not supported (only udp://)' % (url, scheme))
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
    remote = host_port(remote_part, None, default_remote_port, 'remote') if remote_part else (None, None)
    if bind[1] == 0:
        raise UrlError('URL %r: bind port 0 is not allowed' % url)
    return bind, (remote if remote[0] else None)


class _Sink:
    """pymavlink writes packed frames here; the link sends them itself."""

    def write(self, _data):
        pass


class MavlinkLink:
    """A MAVLink 2 UDP endpoint with handler dispatch and remote learning."""

    def __init__(self, bind, remote=None, system_id=1, component_id=1, learn_remote=True):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind(bind)
        except OSError as err:
            self.sock.close()
            raise OSError(err.errno, 'cannot bind UDP %s:%d: %s' % (bind[0], bind[1], err.strerror))
        self.sock.setblocking(False)
        self.bind = self.sock.getsockname()
        self.remote = self._resolve(remote) if remote else None
        self.learn_remote = learn_remote
        self.mav = mavlink.MAVLink(_Sink(), srcSystem=system_id, srcComponent=component_id)
        self._send_lock = threading.Lock()  # pymavlink's sequence counter is not thread-safe
        self.mav.robust_parsing = True
        self.handlers = {}
        self.on_datagram = None  # optional raw hook: on_datagram(bytes) for each datagram with a valid frame
        self.stats = collections.Counter()
        self.last_receive_s = None
        self.signing_required = False
        self._streams = {}  # (link_id, sysid, compid) -> last accepted signing timestamp
        self._signature_failed = False

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

    def fileno(self):
        return self.sock.fileno()

    def on(self, msg_type, handler):
        """Call handler(msg) for every message of type `msg_type` (e.g. 'HEARTBEAT')."""
        self.handlers.setdefault(msg_type, []).append(handler)

    # -- signing ----------------------------------------------------------------------------

    @property
    def signing(self):
        return self.mav.signing.secret_key is not None

    def enable_signing(self, key, timestamp=0, required=True, link_id=0):
        """Sign what we send with `key`; if `required`, drop what is not signed with it."""
        if len(key) != SIGNING_KEY_LENGTH or not any(key):
            raise SigningKeyError('a signing key is 32 bytes, not all zero')
        s = self.mav.signing
        with self._send_lock:
            s.secret_key = bytes(key)
            s.link_id = link_id
            s.timestamp = max(timestamp, signing_timestamp_now())
            s.sign_outgoing = True
            s.allow_unsigned_callback = self._accept_unsigned
        self.mav.check_signature = self._check_signature  # pymavlink's marks the stream before checking
        self.signing_required = required
        self._streams.clear()

    def disable_signing(self):
        s = self.mav.signing
        with self._send_lock:
            s.secret_key, s.sign_outgoing, s.allow_unsigned_callback = None, False, None
        self.signing_required = False

    def _check_signature(self, msgbuf, src_system, src_component):
        """Signature first, then the replay rules, and only a genuine frame moves a stream on."""
        s = self.mav.signing
        expected = hashlib.sha256(s.secret_key + bytes(msgbuf[:-6])).digest()[:6]
        if not hmac.compare_digest(expected, bytes(msgbuf[-6:])):
            self._signature_failed = True
            return False
        link_id = msgbuf[-13]
        timestamp = int.from_bytes(msgbuf[-12:-6], 'little')
        stream = (link_id, src_system, src_component)
        last = self._streams.get(stream)
        if (timestamp <= last) if last is not None else (timestamp + SIGNING_NEW_STREAM_WINDOW < s.timestamp):
            self.stats['replayed'] += 1
            self._signature_failed = True
            return False
        self._streams[stream] = timestamp
        with self._send_lock:  # senders bump the same counter
            s.timestamp = max(s.timestamp, timestamp)
        return True

    def _accept_unsigned(self, _mav, msg_id):
        """pymavlink asks this for an unsigned frame, or a signed one that failed the check."""
        failed, self._signature_failed = self._signature_failed, False
        if not self.signing_required or msg_id in ALWAYS_ACCEPTED_UNSIGNED:
            return True
        if not failed:
            self.stats['unsigned_rejected'] += 1
        else:
            self.stats['bad_signature'] += 1
        kind = mavlink.mavlink_map.get(msg_id)
        self.rejected_log(kind.msgname if kind else 'message id %d' % msg_id, failed)
        return False

    def rejected_log(self, name, bad_signature):
        """Log the first rejections and then every 100th: an attack must not flood the log."""
        total = self.stats['unsigned_rejected'] + self.stats['bad_signature']
        if total <= 3 or total % 100 == 0:
            log.warning('signing: rejected %s %s (%d unsigned, %d badly signed so far)',
                        'a badly signed' if bad_signature else 'an unsigned', name,
                        self.stats['unsigned_rejected'], self.stats['bad_signature'])

    # -- send and receive -------------------------------------------------------------------

    def send(self, msg):
        """Pack and send a pymavlink message; False when no remote is known yet."""
        if self.remote is None:
            return False
        with self._send_lock:
            if self.mav.signing.sign_outgoing:
                s = self.mav.signing
                s.timestamp = max(s.timestamp, signing_timestamp_now())
            data = msg.pack(self.mav)
        return self.send_bytes(data)

    def send_bytes(self, data):
        if self.remote is None:
            return False
        try:
            self.sock.sendto(data, self.remote)
        except OSError as err:
            # ECONNREFUSED: nobody listens there (yet); the link stays up, as UDP does.
            self.stats['send_errors'] += 1
            if err.errno not in (errno.ECONNREFUSED, errno.EAGAIN, errno.ENOBUFS, errno.EHOSTUNREACH):
                raise
            return False
        self.stats['sent'] += 1
        return True

    def receive(self, max_datagrams=256):
        """Drain up to max_datagrams pending datagrams and dispatch what they hold."""
        for _ in range(max_datagrams):
            try:
                data, sender = self.sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return
            except ConnectionRefusedError:
                continue  # an ICMP error for an earlier send, not a datagram
            self.handle_datagram(data, sender)

    def _reset_parser(self):
        mav = self.mav
        mav.buf, mav.buf_index, mav.have_prefix_error = bytearray(), 0, False
        mav.expected_length = mavlink.HEADER_LEN_V1 + 2

    def handle_datagram(self, data, sender=None):
        """Parse one datagram on its own: UDP carries whole frames, so a truncated frame
        at the end of one datagram must not swallow the frames of the next."""
        self.stats['datagrams'] += 1
        self._reset_parser()
        try:
            messages = self.mav.parse_buffer(data) or []
        except Exception:  # pymavlink raises assorted errors on hostile bytes
            self.stats['bad_frames'] += 1
            return
        valid = [m for m in messages if m.get_type() != 'BAD_DATA']
        self.stats['bad_frames'] += len(messages) - len(valid)
        if not valid:
            return
        self.last_receive_s = time.monotonic()
        if sender is not None and self.learn_remote and sender != self.remote and (
                not self.signing or any(m._signed for m in valid)):
            # before dispatch: replies go to whoever asked; with signing on, only a signed
            # frame moves the link (an unsigned RADIO_STATUS is let in, not followed)
            self.remote = sender
        if self.on_datagram is not None:
            self.on_datagram(data)
        for msg in valid:
            self.stats['received'] += 1
            for handler in self.handlers.get(msg.get_type(), ()):
                self._call(handler, msg)

    def _call(self, handler, msg):
        try:
            handler(msg)
        except Exception:  # a handler bug must not take the receive loop down
            self.stats['handler_errors'] += 1
            log.exception('handler %r failed on %s', handler, msg.get_type())

    def close(self):
        self.sock.close()
