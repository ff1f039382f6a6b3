"""A lossy UDP link for tests: sits between the bridge and the simulated PX4.

Side A faces the FCU (the simulator sends to --fcu-port), side B faces the bridge
(its fcu_url sends to --bridge-port). Each side learns its peer from the
first datagram. Every datagram may be dropped, duplicated, delayed or reordered, and the
link can be cut for a while (--cut START:SECONDS, repeatable, seconds after start).
With --control-port, a test acts on it when it wants, by a datagram to that port answered "ok"
(or "error: ..."):
  "cut SECONDS [both|to_fcu|to_bridge]"     cut one or both directions from now on;
  "drop P SECONDS [both|to_fcu|to_bridge]"  a burst of random loss: drop each datagram with
                                            probability P (0..1) from now on, on top of --drop;
  "flush"                                   write out what --record holds and end the recording
                                            (the relay goes on relaying), so the file is whole.
With --record FILE, every datagram that arrives (before any loss) is written to FILE as a pcap
stamped on the simulated clock (offboard_py.conversation.recording): the conversation of the link,
as reference/conversations/ recorded real mavros and real PX4.
Runs as a roslaunch node too (name:=value arguments are ignored), through test/rostest/lossy_relay_node.py.
Loopback only.
"""

import argparse
import collections
import heapq
import math
import random
import select
import socket
import sys

from offboard_py.conversation.recording import PcapWriter
from offboard_py.clock_board import BoardError, ThreadParticipant
from offboard_py.simtime import SimClock, SpeedError


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--fcu-port', type=int, required=True, help='UDP port the FCU sends to')
    p.add_argument('--bridge-port', type=int, required=True, help='UDP port the bridge sends to')
    p.add_argument('--drop', type=float, default=0.0, help='probability of dropping a datagram (0..1)')
    p.add_argument('--duplicate', type=float, default=0.0, help='probability of sending it twice')
    p.add_argument('--delay-ms', type=float, default=0.0, help='delay added to every datagram')
    p.add_argument('--jitter-ms', type=float, default=0.0, help='uniform random extra delay (reorders)')
    p.add_argument('--cut', action='append', default=[], metavar='START:SECONDS', help='cut the link')
    p.add_argument('--control-port', type=int,
                   help='UDP port for "cut SECONDS [direction]" and "drop P SECONDS [direction]" commands')
    p.add_argument('--seed', type=int, default=1)
    p.add_argument('--speed', default='1', metavar='K',
                   help='simulated time at K x real time (as sim_px4 --speed): cuts and delays are in its seconds')
    p.add_argument('--record', metavar='FILE', help='write every datagram to FILE (pcap, simulated-clock stamps)')
    args = p.parse_args([a for a in argv if ':=' not in a])
    for name in ('drop', 'duplicate'):
        if not 0.0 <= getattr(args, name) <= 1.0:
            p.error('--%s must be between 0 and 1' % name)
    try:
        args.cuts = [tuple(float(v) for v in c.split(':')) for c in args.cut]
    except ValueError:
        p.error('--cut takes START:SECONDS')
    return args


DIRECTIONS = {'both': ('fcu', 'bridge'), 'to_bridge': ('fcu',), 'to_fcu': ('bridge',)}  # by receiving side
CONTROL_USAGE = 'expected "cut SECONDS [both|to_fcu|to_bridge]" or "drop P SECONDS [both|to_fcu|to_bridge]"'
MAX_CONTROL_S = 3600.0


class Control(collections.namedtuple('Control', 'action seconds receiving drop')):
    """A control command: action 'cut' or 'drop', for `seconds` (simulated), on the receiving sides
    (DIRECTIONS' values); `drop` is the loss probability of a 'drop' burst (1.0 for a cut)."""


def _number(word, what):
    try:
        value = float(word)
    except ValueError:
        raise ValueError('%s %r is not a number' % (what, word)) from None
    if not math.isfinite(value):
        raise ValueError('%s %r is not a finite number' % (what, word))
    return value


def parse_control(text):
    """'cut SECONDS [direction]' or 'drop P SECONDS [direction]' -> Control. Raises ValueError with the reason."""
    words = text.split()
    arity = {'cut': 1, 'drop': 2}.get(words[0] if words else None)
    if arity is None or len(words) not in (1 + arity, 2 + arity):
        raise ValueError('%s, got %r' % (CONTROL_USAGE, text))
    drop = 1.0
    if words[0] == 'drop':
        drop = _number(words[1], 'loss probability')
        if not 0.0 <= drop <= 1.0:
            raise ValueError('loss probability %g is outside 0..1' % drop)
    seconds = _number(words[arity], '%s length' % words[0])
    if not 0.0 <= seconds <= MAX_CONTROL_S:
        raise ValueError('%s length %g s is outside 0..%g' % (words[0], seconds, MAX_CONTROL_S))
    direction = words[1 + arity] if len(words) == 2 + arity else 'both'
    if direction not in DIRECTIONS:
        raise ValueError('unknown direction %r (both, to_fcu or to_bridge)' % direction)
    return Control(words[0], seconds, DIRECTIONS[direction], drop)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        clock = SimClock.for_run(args.speed)
    except (SpeedError, BoardError) as err:
        print('lossy_relay: %s' % err, file=sys.stderr)
        return 2
    # on a governed clock the relay is a participant: the clock waits while it is off the CPU
    participant = ThreadParticipant(clock.board, 'relay') if clock.board is not None else None
    rng = random.Random(args.seed)
    recorder = None
    if args.record:
        try:
            recorder = PcapWriter(args.record)
        except OSError as err:
            print('lossy_relay: --record %s: %s' % (args.record, err), file=sys.stderr)
            return 2
    sides = {}
    for name, port in (('fcu', args.fcu_port), ('bridge', args.bridge_port)):
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.bind(('127.0.0.1', port))
        sock.setblocking(False)
        sides[name] = sock
    control = None
    if args.control_port:
        control = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        control.bind(('127.0.0.1', args.control_port))
    cut_until = {'fcu': 0.0, 'bridge': 0.0}  # by receiving side: drop what arrives there until then
    burst = {'fcu': (0.0, 0.0), 'bridge': (0.0, 0.0)}  # by receiving side: (until, loss probability)
    peers = {'fcu': None, 'bridge': None}
    other = {'fcu': 'bridge', 'bridge': 'fcu'}
    queue = []  # (due, seq, side to send from, data)
    seq = 0
    start = clock.now()
    stats = {'forwarded': 0, 'dropped': 0, 'duplicated': 0, 'cut': 0, 'burst_dropped': 0}
    try:
        while True:
            timeout = clock.wall_s(max(0.0, queue[0][0] - clock.now())) if queue else 0.5
            readable, _, _ = select.select(list(sides.values()) + ([control] if control else []), [], [], timeout)
            now = clock.now()
            if control in readable:
                text, addr = control.recvfrom(1000)
                if text.strip() == b'flush':
                    if recorder is None:
                        control.sendto(b'error: no --record, or already flushed', addr)
                    else:
                        recorder.close()
                        recorder = None
                        control.sendto(b'ok', addr)
                else:
                    try:
                        command = parse_control(text.decode('ascii', 'replace'))
                    except ValueError as err:
                        control.sendto(b'error: %s' % str(err).encode(), addr)
                    else:
                        for side in command.receiving:
                            if command.action == 'cut':
                                cut_until[side] = now + command.seconds
                            else:
                                burst[side] = (now + command.seconds, command.drop)
                        print('lossy_relay: %s %s for %.1f s%s' % (
                            command.action, '+'.join(command.receiving), command.seconds,
                            '' if command.action == 'cut' else ' (loss %.0f %%)' % (100 * command.drop)), flush=True)
                        control.sendto(b'ok', addr)
            for name, sock in sides.items():
                if sock not in readable:
                    continue
                while True:
                    try:
                        data, addr = sock.recvfrom(65535)
                    except (BlockingIOError, ConnectionRefusedError):
                        break
                    peers[name] = addr
                    if recorder is not None:
                        recorder.write(clock.now(), name == 'fcu', data)
                    elapsed = now - start
                    if now < cut_until[name] or any(s <= elapsed < s + d for s, d in args.cuts):
                        stats['cut'] += 1
                        continue
                    if rng.random() < args.drop:
                        stats['dropped'] += 1
                        continue
                    if now < burst[name][0] and rng.random() < burst[name][1]:
                        stats['burst_dropped'] += 1
                        continue
                    copies = 2 if rng.random() < args.duplicate else 1
                    stats['duplicated'] += copies - 1
                    for _ in range(copies):
                        due = now + (args.delay_ms + rng.uniform(0.0, args.jitter_ms)) / 1000.0
                        seq += 1
                        heapq.heappush(queue, (due, seq, other[name], data))
            while queue and queue[0][0] <= clock.now():
                _, _, side, data = heapq.heappop(queue)
                if peers[side] is not None:
                    try:
                        sides[side].sendto(data, peers[side])
                        stats['forwarded'] += 1
                    except OSError:
                        pass
    except KeyboardInterrupt:
        print('lossy_relay: %s' % stats)
    finally:
        if participant is not None:
            participant.leave()
        if recorder is not None:
            recorder.close()
    return 0

