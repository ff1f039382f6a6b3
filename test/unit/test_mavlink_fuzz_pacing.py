"""The paced sender of the fuzz tests: it reads a loopback receiver's unread backlog and lets the receiver catch up
before the next burst, for a bounded time, so a receiver starved of CPU is not fed a full socket that drops."""

import socket

from offboard_py.testing import mavlink_fuzz


def test_the_backlog_of_a_loopback_socket_is_read_from_proc():
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        receiver.bind(('127.0.0.1', 0))
        port = receiver.getsockname()[1]
        assert mavlink_fuzz.udp_backlog_bytes(port) == 0
        for _ in range(5):
            sender.sendto(b'x' * 100, ('127.0.0.1', port))
        queued = mavlink_fuzz.udp_backlog_bytes(port)
        assert queued is not None and queued >= 500, queued
        for _ in range(5):
            receiver.recv(200)
        assert mavlink_fuzz.udp_backlog_bytes(port) == 0
    finally:
        receiver.close()
        sender.close()
    assert mavlink_fuzz.udp_backlog_bytes(port) is None, 'no socket there'


def test_a_burst_waits_for_the_receiver_to_read_but_not_for_ever(monkeypatch):
    waits = []
    monkeypatch.setattr(mavlink_fuzz.time, 'sleep', lambda s: waits.append(s))
    clock = iter(range(10 ** 6))
    monkeypatch.setattr(mavlink_fuzz.time, 'monotonic', lambda: next(clock) * 0.001)
    reads = iter([10 ** 6] * 3 + [0] * 10 ** 6)   # behind for three looks, then caught up

    class Sock:
        sent = 0

        def sendto(self, data, address):
            Sock.sent += 1

    assert mavlink_fuzz.send_paced(Sock(), ('127.0.0.1', 1), [b'x'] * 80, burst=40,
                                   backlog=lambda port: next(reads)) == 80
    assert Sock.sent == 80
    assert waits.count(0.001) == 3, 'waited while the receiver was behind, and only then'
    stuck = iter([10 ** 6] * 10 ** 6)
    waits.clear()
    mavlink_fuzz.send_paced(Sock(), ('127.0.0.1', 1), [b'x'] * 40, burst=40, backlog=lambda port: next(stuck))
    assert waits.count(0.001) <= mavlink_fuzz.BACKLOG_WAIT_S / 0.001 + 1, 'bounded by BACKLOG_WAIT_S'
