#!/usr/bin/env python3
"""Make bench/data/px4-hover-replay.json.xz from a recorded conversation of real mavros 1.21 with
real PX4 SITL (a pcap of the loopback UDP between PX4's onboard port 14580 and mavros's 14540).

What the replay bench (bench/px4_replay.py) needs of the recording, and nothing else:
- `stream`: PX4's datagrams to mavros in the hover (armed, OFFBOARD, within 0.15 m of the hover
  height), each with its time in us since the window's start, as PX4 sent them (one message a
  datagram); PX4's answers to mavros (TIMESYNC with tc1 set, COMMAND_ACK, PARAM_VALUE, MISSION_*)
  are left out: the replay answers the bridge live;
- `command_acks`: PX4's COMMAND_ACK to each command mavros sent (SET_MODE's is the DO_SET_MODE one);
- `param_values`: PX4's PARAM_VALUEs after mavros's PARAM_REQUEST_LIST, in order;
- `mission_counts`: PX4's MISSION_COUNT (0 items) by mission type.

    python bench/make_px4_replay.py /path/to/takeoff-mavros-px4.pcap.xz [--out bench/data/px4-hover-replay.json.xz]
"""

import argparse
import json
import lzma
import os
import struct
import sys

from offboard_py.dialect import mavlink

PCAP_MAGIC_US, PCAP_MAGIC_NS = 0xa1b2c3d4, 0xa1b23c4d
LINKTYPE_ETHERNET, LINKTYPE_NULL, LINKTYPE_RAW, LINKTYPE_LINUX_SLL, LINKTYPE_LINUX_SLL2 = 1, 0, 101, 113, 276
PX4_PORT, MAVROS_PORT = 14580, 14540
HOVER_HEIGHT_M, HOVER_TOLERANCE_M = 2.0, 0.15  # offb_node's setpoint
SETTLE_S = 2.0  # after first reaching the hover height


def datagrams(path):
    """(t s, sport, dport, payload) of each UDP datagram of a pcap (optionally .xz)."""
    data = (lzma.open if path.endswith('.xz') else open)(path, 'rb').read()
    magic, _, _, _, _, _, linktype = struct.unpack_from('<IHHiIII', data, 0)
    if magic not in (PCAP_MAGIC_US, PCAP_MAGIC_NS):
        raise SystemExit('%s: not a little-endian pcap (magic %#x)' % (path, magic))
    skip = {LINKTYPE_ETHERNET: 14, LINKTYPE_NULL: 4, LINKTYPE_RAW: 0, LINKTYPE_LINUX_SLL: 16,
            LINKTYPE_LINUX_SLL2: 20}.get(linktype)
    if skip is None:
        raise SystemExit('%s: link type %d not read here' % (path, linktype))
    unit = 1e-9 if magic == PCAP_MAGIC_NS else 1e-6
    off = 24
    while off + 16 <= len(data):
        sec, frac, caplen, _ = struct.unpack_from('<IIII', data, off)
        packet = data[off + 16:off + 16 + caplen]
        off += 16 + caplen
        ip = packet[skip:]
        if not ip or ip[0] >> 4 != 4 or ip[9] != 17:
            continue
        ihl = (ip[0] & 15) * 4
        sport, dport, length, _ = struct.unpack_from('>HHHH', ip, ihl)
        yield sec + frac * unit, sport, dport, ip[ihl + 8:ihl + length]


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('pcap')
    p.add_argument('--out', default=os.path.join(os.path.dirname(os.path.abspath(__file__)), 'data',
                                                 'px4-hover-replay.json.xz'))
    args = p.parse_args()
    mav = mavlink.MAVLink(None)
    mav.robust_parsing = True
    fcu, ros = [], []
    t0 = None
    for t, sport, dport, payload in datagrams(args.pcap):
        t0 = t if t0 is None else t0
        msgs = mav.parse_buffer(payload) or []
        if sport == PX4_PORT and dport == MAVROS_PORT:
            if len(msgs) != 1:
                raise SystemExit('a datagram from PX4 at %.3f s holds %d messages, not one' % (t - t0, len(msgs)))
            fcu.append((t - t0, payload, msgs[0]))
        elif sport == MAVROS_PORT and dport == PX4_PORT:
            ros.extend((t - t0, m) for m in msgs)
    # the hover: armed in OFFBOARD (PX4's custom mode 6 << 16) at the height reached, until the mode changes
    offboard = 6 << 16
    start = end = height = None
    for t, _, msg in fcu:
        kind = msg.get_type()
        if kind == 'HEARTBEAT':
            armed = msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            if armed and msg.custom_mode == offboard:
                continue
            if start is not None:
                end = t - 0.5
                break
        elif kind == 'LOCAL_POSITION_NED' and start is None and height is None and -msg.z > HOVER_HEIGHT_M - HOVER_TOLERANCE_M:
            height = t
        if height is not None and start is None and t >= height + SETTLE_S:
            start = t
    if start is None or end is None or end - start < 10.0:
        raise SystemExit('no hover of at least 10 s found (start %s, end %s)' % (start, end))
    answers = ('TIMESYNC', 'COMMAND_ACK', 'PARAM_VALUE', 'MISSION_COUNT', 'MISSION_ITEM_INT', 'MISSION_ACK')
    stream = []
    for t, payload, msg in fcu:
        if start <= t < end:
            kind = msg.get_type()
            if kind in answers and not (kind == 'TIMESYNC' and msg.tc1 == 0):
                continue  # an answer to mavros: answered live by the replay
            stream.append([int(round((t - start) * 1e6)), payload.hex()])
    acks, params, missions = {}, [], {}
    param_list_t = next((t for t, m in ros if m.get_type() == 'PARAM_REQUEST_LIST'), None)
    for t, payload, msg in fcu:
        kind = msg.get_type()
        if kind == 'COMMAND_ACK' and str(msg.command) not in acks:
            acks[str(msg.command)] = payload.hex()
        elif kind == 'PARAM_VALUE' and param_list_t is not None and t >= param_list_t:
            params.append(payload.hex())
        elif kind == 'MISSION_COUNT':
            missions.setdefault(str(msg.mission_type), payload.hex())
    out = {'source': 'takeoff-mavros-px4 (real mavros 1.21 + real PX4 SITL), %s; hover %.3f-%.3f s of the capture'
                     % (os.path.basename(args.pcap), start, end),
           'window_us': int(round((end - start) * 1e6)), 'stream': stream, 'command_acks': acks,
           'param_values': params, 'mission_counts': missions}
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with lzma.open(args.out, 'wt') as f:
        json.dump(out, f, separators=(',', ':'))
    print('%s: %d datagrams in %.1f s (%.0f/s), %d ACKs, %d PARAM_VALUEs, %d MISSION_COUNTs, %d bytes'
          % (args.out, len(stream), out['window_us'] / 1e6, len(stream) / (out['window_us'] / 1e6), len(acks),
             len(params), len(missions), os.path.getsize(args.out)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
