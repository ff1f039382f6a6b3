"""Where a UDP MAVLink link sends: the two rules side by side, chosen by the link's owner.

- `MavconnRemote`: mavros's (mavconn's UDP transport). It starts with the URL's remote (or none) and
  follows the sender of every datagram that carries a valid frame from its peer, saying so as
  mavconn does ("udp0: Remote address: ..."). `learn=False` keeps the URL's remote for good.
- `Px4Partner`: PX4's (mavlink_receiver.cpp, v1.10 to main). Until the partner is known, the sender
  of a datagram becomes the partner, for good, when the default partner is 127.0.0.1 (PX4 SITL's,
  so the first datagram whatever it holds, taken before parsing) or once LOCK_GRACE_S have passed
  since the link started; a datagram that does not lock it is dropped unread. PX4 never moves the
  partner again: a flood from another port is read, but the telemetry and replies stay where they went.

Both answer the same two questions of MavlinkLink: admit(sender) before a datagram is read (False:
drop it unread), and heard(sender) after a datagram with a valid frame from the peer was read;
`replies_stay_with_partner` says whether a datagram from another sender is answered elsewhere.
`address` is where to send now (None: nowhere yet).
"""

import ipaddress
import logging

log = logging.getLogger(__name__)

LOCK_GRACE_S = 3.0


def on_this_host(address):
    """True for a loopback or unspecified (0.0.0.0: this host) address, or none."""
    if address is None:
        return True
    try:
        host = ipaddress.ip_address(address[0])
    except ValueError:
        return False
    return host.is_loopback or host.is_unspecified


class MavconnRemote:
    """mavconn's rule: follow the peer's latest sender (learn), or keep the first remote."""

    replies_stay_with_partner = False  # whoever the peer last sent from gets the replies

    def __init__(self, address, name, learn=True):
        self.address = address
        self.name = name
        self.learn = learn
        self.changes = 0

    def admit(self, sender):
        return True

    def heard(self, sender):
        if not self.learn or sender is None or sender == self.address:
            return
        self.address = sender
        self.changes += 1
        # after 10 moves only every 100th is logged (a hostile sender could move it often)
        if self.changes <= 10 or self.changes % 100 == 0:
            log.info('%s: Remote address: %s:%d%s', self.name, sender[0], sender[1],
                     '' if self.changes <= 10 else ' (%d changes)' % self.changes)


class Px4Partner:
    """PX4's rule: the first sender (after the grace, for a partner that is not local) for good."""

    replies_stay_with_partner = True  # another sender is read, but not answered

    def __init__(self, address, name, clock):
        self.address = address
        self.name = name
        self.clock = clock
        self.locked = False
        self.changes = 0
        self.lock_after_s = None if on_this_host(address) else clock() + LOCK_GRACE_S

    def admit(self, sender):
        if self.locked or sender is None:
            return True
        if self.lock_after_s is not None and self.clock() < self.lock_after_s:
            return False
        self.address = sender
        self.locked = True
        log.info('%s: partner address %s:%d (kept for good, as PX4 does)', self.name, sender[0], sender[1])
        return True

    def heard(self, sender):
        pass  # never moved once locked
