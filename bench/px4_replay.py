#!/usr/bin/env python3
"""A PX4-shaped stream at the bridge: real PX4 SITL's hover, recorded, replayed at mavros's FCU port.

bench/data/px4-hover-replay.json.xz (made by bench/make_px4_replay.py) holds PX4's datagrams to mavros in
a recorded hover, one MAVLink message each (about 406 a second, PX4's own TIMESYNC requests included).
This sends them from PX4's port at their recorded times, looped: each pass moves the FCU's clock fields
(time_boot_ms, time_usec, a TIMESYNC request's ts1) on by the window's length and numbers the frames on,
so the bridge sees one boot's steady stream. It answers what the bridge asks as the recording shows:
TIMESYNC requests live (ts1 echoed, tc1 the replay's boot clock in ns), COMMAND_LONG and SET_MODE with
PX4's recorded COMMAND_ACK, PARAM_REQUEST_LIST with PX4's recorded PARAM_VALUEs, MISSION_REQUEST_LIST
with PX4's MISSION_COUNT 0. Setpoints that arrive are logged (arrival ns, time_boot_ms) for the latency.

    python bench/px4_replay.py [--port 14580] [--bridge-port 14540] [--setpoint-log FILE] [--stats FILE]

Runs until SIGINT or SIGTERM, then writes the logs.
"""

import argparse
import collections
import json
import lzma
import os
import select
import signal
import socket
import sys
import time

from offboard_py.dialect import mavlink

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'data', 'px4-hover-replay.json.xz')
PARAM_SPACING_S = 0.001  # PX4 sent the 888 parameters in about 0.8 s


class _Sink:
    def write(self, _data):
        pass


def _decode(hex_frame):
    mav = mavlink.MAVLink(None)
    msgs = mav.parse_buffer(bytes.fromhex(hex_frame)) or []
    if len(msgs) != 1:
        raise ValueError('a recorded datagram holds %d messages, not one' % len(msgs))
    if isinstance(msgs[0], mavlink.MAVLink_unknown):
        return _Raw(bytes.fromhex(hex_frame))
    return msgs[0]


class _Raw:
    """A recorded frame of a message this dialect does not know (PX4's CURRENT_EVENT_SEQUENCE): sent as
    recorded, renumbered, its CRC made again with the CRC_EXTRA that makes the recorded one."""

    def __init__(self, frame):
        self.frame = bytearray(frame)
        body = bytes(frame[1:-2])
        crc = frame[-2] | frame[-1] << 8
        self.extra = next(e for e in range(256) if mavlink.x25crc(body + bytes((e,))).crc == crc)

    def get_type(self):
        return 'UNKNOWN'

    def get_fieldnames(self):
        return []

    def get_srcSystem(self):
        return self.frame[5]

    def get_srcComponent(self):
        return self.frame[6]

    def pack(self, mav):
        self.frame[4] = mav.seq
        crc = mavlink.x25crc(bytes(self.frame[1:-2]) + bytes((self.extra,))).crc
        self.frame[-2:] = bytes((crc & 0xFF, crc >> 8))
        return bytes(self.frame)


class Replay:
    """The recorded stream and answers, sent through `sock` to `bridge` (host, port)."""

    def __init__(self, data, sock, bridge, clock=time.monotonic):
        self.sock, self.bridge, self.clock = sock, bridge, clock
        self.window_us = data['window_us']
        self.stream = [(t_us, _decode(frame)) for t_us, frame in data['stream']]
        # per frame: its clock fields (name, recorded value, units of a us)
        self.clock_fields = []
        boot0_us = None
        for t_us, msg in self.stream:
            fields = []
            names = msg.get_fieldnames()
            if 'time_boot_ms' in names:
                fields.append(('time_boot_ms', msg.time_boot_ms, 1e-3))
                boot0_us = boot0_us if boot0_us is not None else msg.time_boot_ms * 1000 - t_us
            if 'time_usec' in names and msg.time_usec:
                fields.append(('time_usec', msg.time_usec, 1.0))
            if msg.get_type() == 'TIMESYNC':
                fields.append(('ts1', msg.ts1, 1e3))
            self.clock_fields.append(fields)
        self.boot0_us = boot0_us or 0
        self.acks = {int(cmd): _decode(frame) for cmd, frame in data['command_acks'].items()}
        self.params = [_decode(frame) for frame in data['param_values']]
        self.missions = {int(kind): _decode(frame) for kind, frame in data['mission_counts'].items()}
        self.mavs = {}
        self.seq = 0
        self.counts = collections.Counter()
        self.setpoints = []  # (arrival ns, time_boot_ms)
        self.timesync_sent = {}  # ts1 of a TIMESYNC request sent -> when (s)
        self.timesync_rtt_ms = []  # how long the bridge took to answer each
        self.queue = collections.deque()  # (due s, msg): answers paced as PX4 paced them
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True

    def boot_us(self, now_s):
        return self.boot0_us + (now_s - self.start_s) * 1e6

    def send(self, msg, source=None):
        key = source or (msg.get_srcSystem(), msg.get_srcComponent())
        mav = self.mavs.get(key)
        if mav is None:
            mav = self.mavs[key] = mavlink.MAVLink(_Sink(), srcSystem=key[0], srcComponent=key[1])
        mav.seq = self.seq
        self.seq = (self.seq + 1) & 0xFF
        try:
            self.sock.sendto(msg.pack(mav), self.bridge)
            self.counts['sent'] += 1
        except OSError:
            self.counts['send_errors'] += 1

    def answer(self, msg, now_s):
        kind = msg.get_type()
        self.counts['in ' + kind] += 1
        if kind == 'SET_POSITION_TARGET_LOCAL_NED':
            self.setpoints.append((time.time_ns(), msg.time_boot_ms))
        elif kind == 'TIMESYNC' and msg.tc1 != 0:  # the bridge answers PX4's request
            sent_s = self.timesync_sent.pop(msg.ts1, None)
            if sent_s is not None:
                self.timesync_rtt_ms.append((now_s - sent_s) * 1e3)
        elif kind == 'TIMESYNC' and msg.tc1 == 0:
            reply = mavlink.MAVLink_timesync_message(int(self.boot_us(now_s) * 1000), msg.ts1)
            first = self.stream[0][1]  # from the autopilot's system and component
            self.send(reply, (first.get_srcSystem(), first.get_srcComponent()))
        elif kind in ('COMMAND_LONG', 'SET_MODE'):
            command = msg.command if kind == 'COMMAND_LONG' else mavlink.MAV_CMD_DO_SET_MODE
            if command in self.acks:
                self.send(self.acks[command])
            else:
                self.counts['unanswered COMMAND %d' % command] += 1
        elif kind == 'PARAM_REQUEST_LIST':
            self.queue.extend((now_s + i * PARAM_SPACING_S, p) for i, p in enumerate(self.params))
        elif kind == 'PARAM_REQUEST_READ':
            match = [p for p in self.params if p.param_index == msg.param_index or (
                msg.param_index < 0 and p.param_id == msg.param_id)]
            if match:
                self.send(match[0])
        elif kind == 'MISSION_REQUEST_LIST':
            count = self.missions.get(msg.mission_type)
            if count is not None:
                self.send(count)

    def run(self, stopped):
        self.start_s = self.clock()
        index, passes = 0, 0
        while not stopped():
            now_s = self.clock()
            due_s = self.start_s + (passes * self.window_us + self.stream[index][0]) / 1e6
            while now_s >= due_s:
                msg = self.stream[index][1]
                for name, value, per_us in self.clock_fields[index]:
                    setattr(msg, name, int(value + passes * self.window_us * per_us))
                self.send(msg)
                if self.clock_fields[index] and msg.get_type() == 'TIMESYNC':
                    self.timesync_sent[msg.ts1] = now_s
                index += 1
                if index == len(self.stream):
                    index, passes = 0, passes + 1
                due_s = self.start_s + (passes * self.window_us + self.stream[index][0]) / 1e6
            while self.queue and now_s >= self.queue[0][0]:
                self.send(self.queue.popleft()[1])
            if self.queue:
                due_s = min(due_s, self.queue[0][0])
            readable, _, _ = select.select([self.sock], [], [], max(0.0, due_s - self.clock()))
            if readable:
                while True:
                    try:
                        data, _ = self.sock.recvfrom(65535)
                    except (BlockingIOError, InterruptedError):
                        break
                    except ConnectionRefusedError:
                        continue
                    for msg in self.parser.parse_buffer(data) or []:
                        self.answer(msg, self.clock())
        self.counts['passes'] = passes
        rtts = sorted(self.timesync_rtt_ms)
        if rtts:
            self.counts['timesync answer ms p50'] = rtts[len(rtts) // 2]
            self.counts['timesync answer ms p99'] = rtts[min(len(rtts) - 1, int(len(rtts) * 0.99))]
            self.counts['timesync answer ms max'] = rtts[-1]


def load(path=DATA):
    with lzma.open(path, 'rt') as f:
        return json.load(f)


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--port', type=int, default=14580, help="PX4 SITL's onboard port, bound here (14580)")
    p.add_argument('--bridge-port', type=int, default=14540, help="mavros's FCU port on loopback (14540)")
    p.add_argument('--data', default=DATA)
    p.add_argument('--setpoint-log', help='at exit: a line "arrival_ns time_boot_ms" per setpoint received')
    p.add_argument('--stats', help='at exit: counts (JSON) of what was sent and received')
    args = p.parse_args()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(('127.0.0.1', args.port))
    sock.setblocking(False)
    replay = Replay(load(args.data), sock, ('127.0.0.1', args.bridge_port))
    stop = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(True))
    replay.run(lambda: bool(stop))
    if args.setpoint_log:
        with open(args.setpoint_log, 'w') as out:
            out.writelines('%d %d\n' % row for row in replay.setpoints)
    if args.stats:
        with open(args.stats, 'w') as out:
            json.dump(dict(replay.counts), out, indent=1, sort_keys=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
