"""The bridge's receive loop on a real UDP socket: while it reads a backlog it says since when
(Bridge.unread_since_s, which holds the governed clock: offboard_py.bridge.node._clock_limit), and once
read to the end it is caught up (None). So a conn/timeout under a flood never fires with the HEARTBEAT
that ends it still unread in the socket."""

import socket
import time

from offboard_py.bridge.config import read_config
from offboard_py.bridge.core import RECEIVE_BATCH, Bridge
from offboard_py.mavlink_link import MavlinkLink

from bridge_rig import FakeRos, heartbeat

BACKLOG = 4 * RECEIVE_BATCH
BOUND_S = 10.0


def wait_for(condition, what):
    deadline = time.monotonic() + BOUND_S
    while not condition():
        assert time.monotonic() < deadline, 'not within %.0f s: %s' % (BOUND_S, what)
        time.sleep(0.005)


def test_a_backlog_holds_the_clock_until_it_is_read():
    link = MavlinkLink(('127.0.0.1', 0), ('127.0.0.1', 14580), system_id=1, component_id=240, peer=(1, 1))
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sender.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 20)
    bridge = Bridge(read_config(lambda name, default: default), link, FakeRos(), (), clock=time.monotonic)
    seen = []
    bridge.on('HEARTBEAT', lambda msg: seen.append(bridge.unread_since_s))
    try:
        link.transport.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
        frame = heartbeat().pack(link.mav.__class__(None, srcSystem=1, srcComponent=1))
        for _ in range(BACKLOG):  # all in the socket before the loop first wakes
            sender.sendto(frame, link.transport.bind)
        woken_after = time.monotonic()
        bridge.start()
        wait_for(lambda: len(seen) == BACKLOG, 'the bridge read %d of %d HEARTBEATs' % (len(seen), BACKLOG))
        assert all(since is not None and since >= woken_after for since in seen), \
            'reading a backlog of %d datagrams, the loop said it was caught up' % BACKLOG
        assert len(set(seen)) == 1, 'one wake-up read the whole backlog: %s' % sorted(set(seen))
        wait_for(lambda: bridge.unread_since_s is None, 'the loop caught up after reading the backlog')
        sender.sendto(frame, link.transport.bind)  # one datagram: read to the end at once
        wait_for(lambda: len(seen) == BACKLOG + 1, 'the single HEARTBEAT after the backlog')
        wait_for(lambda: bridge.unread_since_s is None, 'caught up after one datagram')
    finally:
        bridge.stop()
        sender.close()
