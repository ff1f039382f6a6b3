"""Hostile MAVLink datagrams for the fuzz tests of the simulated PX4 and of the bridge.

`hostile_datagrams(rng, count, corruptible, ignorable, refused)` cycles through: random
bytes; frames of `corruptible` with 1..3 flipped bits (bad CRC) or cut short; frames with
unknown message ids; frames of `ignorable` (for another system or component, MAVLink 1
and 2); frames of `refused` (valid, addressed to the receiver, but to be rejected:
out-of-range enums, NaN fields); and datagrams holding several of these with garbage
between. Every list holds packed frames (bytes). The number of frames to send comes from
OFFBOARD_PY_FUZZ_FRAMES (10 000 unless set; `./run fuzz` sets 100 000).

`send_paced` sends a fixed number as fast as the receiver can take them; `flood` sends at a given
rate (datagrams/s) until told to stop, as a process of its own (`Flood`), for measurements under load.
"""

import itertools
import multiprocessing
import os
import socket
import struct
import time

KINDS = ('random', 'bitflip', 'truncated', 'unknown_id', 'ignorable', 'refused', 'mixed')


def frame_count(default=10000):
    return int(os.environ.get('OFFBOARD_PY_FUZZ_FRAMES', default))


def hostile_datagrams(rng, count, corruptible, ignorable, refused):
    for i in range(count):
        kind = KINDS[i % len(KINDS)]
        if kind == 'random':
            yield bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 280)))
        elif kind == 'bitflip':
            frame = bytearray(rng.choice(corruptible))
            for bit in rng.sample(range(8, len(frame) * 8), rng.randint(1, 3)):  # distinct bits: never a no-op
                frame[bit // 8] ^= 1 << (bit % 8)
            yield bytes(frame)
        elif kind == 'truncated':
            frame = rng.choice(corruptible)
            yield frame[:rng.randint(1, len(frame) - 1)]
        elif kind == 'unknown_id':
            payload = bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 40)))
            msgid = rng.randint(20000, 0xFFFFFF)
            header = struct.pack('<BBBBBBB', 0xFD, len(payload), 0, 0, i & 0xFF, 200, 1) + msgid.to_bytes(3, 'little')
            yield header + payload + bytes(rng.getrandbits(8) for _ in range(2))
        elif kind == 'ignorable':
            yield rng.choice(ignorable)
        elif kind == 'refused':
            yield rng.choice(refused)
        else:
            yield b''.join(rng.choice(ignorable + refused) + bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 5)))
                           for _ in range(rng.randint(2, 5)))


BACKLOG_BYTES = 32768    # a receiver with more than this unread in its socket is let read first
BACKLOG_WAIT_S = 1.0     # at most this long (wall) after a burst


def udp_backlog_bytes(port, proc_net='/proc/net/udp'):
    """Bytes queued unread at the UDP socket bound to `port` in this network namespace (rx_queue of
    /proc/net/udp), or None where it is not to be read (no such socket, another system)."""
    try:
        with open(proc_net) as f:
            next(f)
            for line in f:
                fields = line.split()
                if int(fields[1].rsplit(':', 1)[1], 16) == port:
                    return int(fields[4].split(':')[1], 16)
    except (OSError, ValueError, IndexError, StopIteration):
        return None
    return None


def send_paced(sock, address, datagrams, burst=40, pause_s=0.004, backlog=udp_backlog_bytes):
    """Send every datagram, pausing after each burst so the kernel delivers them all: the receiver's unread
    backlog (a loopback receiver's socket) is let fall under BACKLOG_BYTES first, for at most BACKLOG_WAIT_S, so a
    receiver starved of CPU meets the same datagrams as an idle one, not a full socket that drops them. Return
    the count."""
    sent = 0
    for data in datagrams:
        sock.sendto(data, address)
        sent += 1
        if sent % burst == 0:
            time.sleep(pause_s)
            deadline = time.monotonic() + BACKLOG_WAIT_S
            while time.monotonic() < deadline and (backlog(address[1]) or 0) > BACKLOG_BYTES:
                time.sleep(0.001)
    return sent


FLOOD_TICK_S = 0.002  # the flood sends what is due every tick: at 8000/s, 16 datagrams at a time


def flood(address, pool, rate_hz, stop, sent, errors):
    """Send the datagrams of `pool` over and over to `address` at rate_hz (datagrams per wall second)
    until the event `stop` is set; `sent` and `errors` (multiprocessing.Value) count them. A send
    refused (nobody bound there yet) is counted and the flood goes on."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    datagrams = itertools.cycle(pool)
    start = time.monotonic()
    count = failed = 0
    try:
        while not stop.is_set():
            due = int((time.monotonic() - start) * rate_hz)
            if due - count > rate_hz:  # more than a second behind (this machine cannot send so many):
                start = time.monotonic() - count / rate_hz  # send as fast as it can, without a backlog
                due = count + 1
            while count < due:
                try:
                    sock.sendto(next(datagrams), address)
                except OSError:
                    failed += 1
                count += 1
            sent.value, errors.value = count - failed, failed
            time.sleep(FLOOD_TICK_S)
    finally:
        sock.close()


class Flood:
    """`flood` in a process of its own (the sender's Python must not share a GIL with the measurement).
    start() returns at once; stop() ends it (bounded) and returns (datagrams sent, send errors, seconds)."""

    STOP_TIMEOUT_S = 5.0

    def __init__(self, address, pool, rate_hz):
        if rate_hz <= 0:
            raise ValueError('flood rate must be above 0 datagrams/s, got %r' % (rate_hz,))
        if not pool:
            raise ValueError('flood: no datagrams to send')
        ctx = multiprocessing.get_context('spawn')  # no fork of a process that runs rospy threads
        self._stop = ctx.Event()
        self._sent, self._errors = ctx.Value('q', 0), ctx.Value('q', 0)
        self._proc = ctx.Process(target=flood, name='junk-flood', daemon=True,
                                 args=(address, list(pool), rate_hz, self._stop, self._sent, self._errors))
        self._started_s = None

    def start(self):
        self._proc.start()
        self._started_s = time.monotonic()

    def stop(self):
        self._stop.set()
        self._proc.join(self.STOP_TIMEOUT_S)
        if self._proc.is_alive():
            self._proc.kill()
            self._proc.join(self.STOP_TIMEOUT_S)
        took = time.monotonic() - self._started_s if self._started_s is not None else 0.0
        return self._sent.value, self._errors.value, took
