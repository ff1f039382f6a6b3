"""Hostile MAVLink datagrams for the fuzz tests of the simulated PX4 and of the bridge.

`hostile_datagrams(rng, count, corruptible, ignorable, refused)` cycles through: random
bytes; frames of `corruptible` with 1..3 flipped bits (bad CRC) or cut short; frames with
unknown message ids; frames of `ignorable` (for another system or component, MAVLink 1
and 2); frames of `refused` (valid, addressed to the receiver, but to be rejected:
out-of-range enums, NaN fields); and datagrams holding several of these with garbage
between. Every list holds packed frames (bytes). The number of frames to send comes from
OFFBOARD_PY_FUZZ_FRAMES (10 000 unless set; `./run fuzz` sets 100 000).
"""

import os
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


def send_paced(sock, address, datagrams, burst=40, pause_s=0.004):
    """Send every datagram, pausing after each burst so the kernel delivers them all; return the count."""
    sent = 0
    for data in datagrams:
        sock.sendto(data, address)
        sent += 1
        if sent % burst == 0:
            time.sleep(pause_s)
    return sent
