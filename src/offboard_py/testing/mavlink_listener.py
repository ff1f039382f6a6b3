"""A raw MAVLink endpoint on a UDP port of 127.0.0.1: one receive thread records every message.

Plays a ground station on the bridge's gcs_url, or an FCU for a bridge under test. It parses
with robust_parsing, so garbage is skipped, and it never answers by itself.
"""

import socket
import threading
import time

from offboard_py.dialect import mavlink


class MavlinkListener:
    """Binds `port`; `received` holds (arrival time, message); send() goes to `remote_port`."""

    def __init__(self, port, remote_port=None, src_system=1, src_component=1, clock=time.monotonic):
        """`clock` stamps arrivals: pass the test's ROS clock (rostest_common.now) in simulated time."""
        self.clock = clock
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(('127.0.0.1', port))
        self.sock.settimeout(0.1)
        self.remote = ('127.0.0.1', remote_port) if remote_port else None
        self.mav = mavlink.MAVLink(None, srcSystem=src_system, srcComponent=src_component)
        self.lock = threading.Lock()
        self.received = []
        self.senders = {}  # message type -> the set of (host, port) it came from
        self.running = True
        self._rx = threading.Thread(target=self._receive, daemon=True)
        self._rx.start()

    def _receive(self):
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        while self.running:
            try:
                data, sender = self.sock.recvfrom(4096)
            except socket.timeout:
                continue
            now = self.clock()
            for msg in parser.parse_buffer(data) or []:
                if msg.get_type() != 'BAD_DATA':
                    with self.lock:
                        self.received.append((now, msg))
                        self.senders.setdefault(msg.get_type(), set()).add(sender)

    def send(self, msg):
        self.sock.sendto(msg.pack(self.mav), self.remote)

    def of_type(self, name, since=None):
        """Messages of type `name` in arrival order, those after time `since` (of the clock) if given."""
        with self.lock:
            return [m for t, m in self.received if m.get_type() == name and (since is None or t > since)]

    def timed(self, name):
        """(arrival time, message) of type `name`."""
        with self.lock:
            return [(t, m) for t, m in self.received if m.get_type() == name]

    def close(self):
        self.running = False
        self._rx.join(1.0)
        self.sock.close()
