"""MAVLink 2 message signing for one link, as PX4 does it with a key on its SD card.

- The key file is PX4's (`mavlink/mavlink-signing-key.bin`): 32 key bytes, optionally
  followed by the 64-bit little-endian timestamp. `read_signing_key`/`write_signing_key`.
- `LinkSigning` signs every frame a link sends and, when signing is required, drops a
  received frame without a valid signature, counting it (`unsigned_rejected`,
  `bad_signature`, `replayed`), except the few messages PX4 always takes unsigned.
- The signature is checked before the replay rules, and only a genuine frame moves a
  stream's timestamp on: pymavlink's own check records the timestamp first, so one forged
  far-future frame would lock the real sender out. We replace that check.

Knows nothing of sockets: `MavlinkLink` owns one `LinkSigning` and calls it.
"""

import hashlib
import hmac
import logging
import os
import struct
import time

from offboard_py.dialect import mavlink

MAGIC_V2, IFLAG_SIGNED = mavlink.PROTOCOL_MARKER_V2, mavlink.MAVLINK_IFLAG_SIGNED

# Timestamps count 10 us units since 2015-01-01 00:00:00 UTC.
SIGNING_EPOCH_UNIX_S = 1420070400
SIGNING_KEY_LENGTH = 32
# A new stream is accepted only if its timestamp is at most one minute behind ours.
NEW_STREAM_WINDOW = 60 * 100000
# What PX4 accepts unsigned even when signing is required (mavlink_sign_control.cpp).
ALWAYS_ACCEPTED_UNSIGNED = frozenset((mavlink.MAVLINK_MSG_ID_RADIO_STATUS, mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE,
                                      mavlink.MAVLINK_MSG_ID_COLLISION))

log = logging.getLogger(__name__)


class SigningKeyError(ValueError):
    """A signing key that cannot be used; the message names the file."""


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


class LinkSigning:
    """The signing state of one link: pymavlink's `mav.signing` plus our checks and counters.

    `send_lock` is the link's: senders and the receive path both move the timestamp on.
    """

    def __init__(self, mav, send_lock, stats):
        self.mav, self._send_lock, self.stats = mav, send_lock, stats
        self.required = False
        self._streams = {}  # (link_id, sysid, compid) -> last accepted timestamp

    @property
    def active(self):
        return self.mav.signing.secret_key is not None

    def enable(self, key, timestamp=0, required=True, link_id=0):
        """Sign what we send with `key`; if `required`, drop what is not signed with it."""
        if len(key) != SIGNING_KEY_LENGTH or not any(key):
            raise SigningKeyError('a signing key is 32 bytes, not all zero')
        s = self.mav.signing
        with self._send_lock:
            s.secret_key = bytes(key)
            s.link_id = link_id
            s.timestamp = max(timestamp, signing_timestamp_now())
            s.sign_outgoing = True
        self.required = required
        self._streams.clear()

    def disable(self):
        s = self.mav.signing
        with self._send_lock:
            s.secret_key, s.sign_outgoing = None, False
        self.required = False

    def stamp_outgoing(self):
        """Before packing a frame (under the send lock): the timestamp never runs behind the clock."""
        s = self.mav.signing
        if s.sign_outgoing:
            s.timestamp = max(s.timestamp, signing_timestamp_now())

    def admit(self, frame, msg_id):
        """Whether a received frame (CRC checked) is let in, and whether it came with a good signature:
        (admitted, signed). The link checks every frame here before pymavlink decodes it (with no key:
        pymavlink's own check, whose replay rule is not PX4's, never runs). Without signing everything is
        admitted; with it a frame with a good signature is, and any other only when signing is not
        required or it is one MAVLink lets in unsigned (RADIO_STATUS)."""
        if not self.active:
            return True, False
        if frame[0] == MAGIC_V2 and frame[2] & IFLAG_SIGNED:
            if self._check_signature(frame, frame[5], frame[6]):
                return True, True
            bad_signature = True
        else:
            bad_signature = False
        if not self.required or msg_id in ALWAYS_ACCEPTED_UNSIGNED:
            return True, False
        self.stats['bad_signature' if bad_signature else 'unsigned_rejected'] += 1
        kind = mavlink.mavlink_map.get(msg_id)
        self._log_rejection(kind.msgname if kind else 'message id %d' % msg_id, bad_signature)
        return False, False

    def _check_signature(self, msgbuf, src_system, src_component):
        s = self.mav.signing
        expected = hashlib.sha256(s.secret_key + bytes(msgbuf[:-6])).digest()[:6]
        if not hmac.compare_digest(expected, bytes(msgbuf[-6:])):
            return False
        link_id = msgbuf[-13]
        timestamp = int.from_bytes(msgbuf[-12:-6], 'little')
        stream = (link_id, src_system, src_component)
        last = self._streams.get(stream)
        if (timestamp <= last) if last is not None else (timestamp + NEW_STREAM_WINDOW < s.timestamp):
            self.stats['replayed'] += 1
            return False
        self._streams[stream] = timestamp
        with self._send_lock:
            s.timestamp = max(s.timestamp, timestamp)
        return True

    def _log_rejection(self, name, bad_signature):
        """The first rejections and then every 100th: an attack must not flood the log."""
        total = self.stats['unsigned_rejected'] + self.stats['bad_signature']
        if total <= 3 or total % 100 == 0:
            log.warning('signing: rejected %s %s (%d unsigned, %d badly signed so far)',
                        'a badly signed' if bad_signature else 'an unsigned', name,
                        self.stats['unsigned_rejected'], self.stats['bad_signature'])
