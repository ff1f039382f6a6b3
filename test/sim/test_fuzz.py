"""Hostile input to the simulated PX4: no crash, no hang, no state change from what PX4 rejects.

10 000 datagrams (`./run fuzz` sends 100 000): random bytes, valid frames
with flipped bits (bad CRC), truncated frames, unknown message ids, valid frames for another
system (MAVLink 1 and 2), out-of-range enums and NaN fields for this system.
"""

import math
import random
import socket

from pymavlink.dialects.v10 import common as mavlink1

from offboard_py import px4_modes
from offboard_py.dialect import ARM_DISARM_FORCE_MAGIC
from offboard_py.dialect import mavlink as mavlink2
from offboard_py.testing import mavlink_fuzz, ports
from offboard_py.testing.mavros_typemasks import POSITION_AND_YAW
from offboard_py.testing.sim_client import ACCEPTED

FRAMES = mavlink_fuzz.frame_count()
ARM, SET_MODE = mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, mavlink2.MAV_CMD_DO_SET_MODE
CUSTOM = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
OFFBOARD = px4_modes.encode('OFFBOARD')
REAL32, INT32 = mavlink2.MAV_PARAM_TYPE_REAL32, mavlink2.MAV_PARAM_TYPE_INT32
LOCAL_NED = mavlink2.MAV_FRAME_LOCAL_NED
MISSION = mavlink2.MAV_MISSION_TYPE_MISSION


def hostile_frames(rng, count, target):
    v2 = mavlink2.MAVLink(None, srcSystem=200, srcComponent=1)
    v1 = mavlink1.MAVLink(None, srcSystem=201, srcComponent=1)
    nan = float('nan')
    valid_for_us = [
        v2.command_long_encode(target, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0),                 # arm (corrupted below)
        v2.set_mode_encode(target, CUSTOM, OFFBOARD),
        v2.param_set_encode(target, 1, b'MIS_TAKEOFF_ALT', 9.0, REAL32),
        v2.mission_clear_all_encode(target, 1, MISSION),
    ]
    other_system = [
        v2.command_long_encode(42, 1, ARM, 0, 1, ARM_DISARM_FORCE_MAGIC, 0, 0, 0, 0, 0),
        v2.set_mode_encode(42, CUSTOM, OFFBOARD),
        v2.param_set_encode(42, 1, b'MIS_TAKEOFF_ALT', 9.0, REAL32),
        v2.mission_count_encode(42, 1, 5, MISSION),
        v1.command_long_encode(43, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0),
        v1.set_mode_encode(43, CUSTOM, OFFBOARD),
        v1.param_set_encode(43, 1, b'COM_OF_LOSS_T', 9.0, REAL32),
    ]
    auto, ready = px4_modes.MAIN_AUTO, px4_modes.SUB_READY
    rejected_by_px4 = [
        v2.set_mode_encode(target, CUSTOM, px4_modes.join(99, 0)),                      # no such main mode
        v2.set_mode_encode(target, CUSTOM, px4_modes.join(auto, 77)),                   # no such sub mode
        v2.command_long_encode(target, 1, SET_MODE, 0, CUSTOM, auto, ready, 0, 0, 0, 0),  # AUTO.READY: refused
        v2.command_long_encode(target, 1, ARM, 0, 2.0, 0, 0, 0, 0, 0, 0),               # arm action 2: UNSUPPORTED
        v2.command_long_encode(target, 1, SET_MODE, 0, nan, nan, nan, 0, 0, 0, 0),      # NaN mode
        v2.command_long_encode(target, 1, ARM, 0, nan, 0, 0, 0, 0, 0, 0),               # NaN: PX4 disarms (lroundf)
        v2.param_set_encode(target, 1, b'MIS_TAKEOFF_ALT', nan, REAL32),                # NaN float parameter
        v2.param_set_encode(target, 1, b'COM_OBL_RC_ACT', nan, INT32),                  # NaN int parameter
        v2.param_set_encode(target, 1, b'COM_OF_LOSS_T', 1e9, REAL32),                  # out of range
        v2.param_set_encode(target, 1, b'NO_SUCH_PARAM', 1.0, REAL32),
        v2.set_position_target_local_ned_encode(0, target, 1, 99, POSITION_AND_YAW,     # no such frame
                                                0, 0, -2, 0, 0, 0, 0, 0, 0, 0, 0),
        v2.set_position_target_local_ned_encode(0, target, 1, LOCAL_NED, POSITION_AND_YAW,
                                                nan, nan, nan, 0, 0, 0, 0, 0, 0, nan, 0),
        v2.set_position_target_local_ned_encode(0, target, 1, LOCAL_NED, POSITION_AND_YAW,
                                                0, 0, math.inf, 0, 0, 0, 0, 0, 0, 0, 0),
        v2.mission_item_int_encode(target, 1, 3, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                   mavlink2.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0, 0, 0, 5.0, MISSION),  # no upload
        v2.mission_request_int_encode(target, 1, 9999, MISSION),
        v2.mission_count_encode(target, 1, 60000, MISSION),                               # too many items
    ]
    return mavlink_fuzz.hostile_datagrams(
        rng, count, corruptible=[m.pack(v2) for m in valid_for_us],
        ignorable=[m.pack(v2) for m in other_system[:4]] + [m.pack(v1) for m in other_system[4:]],
        refused=[m.pack(v2) for m in rejected_by_px4])


def test_fuzz_changes_nothing(start_sim):
    sim, client = start_sim('--ready-delay', '1')
    client.sleep(1.2)
    names = ('MIS_TAKEOFF_ALT', 'COM_OF_LOSS_T', 'COM_OBL_RC_ACT')
    before = {name: client.read_param(name).param_value for name in names}
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rng = random.Random(2026)
    started = client.now()
    fcu = ('127.0.0.1', ports.fcu_port(sim.instance))
    assert mavlink_fuzz.send_paced(raw, fcu, hostile_frames(rng, FRAMES, client.target)) == FRAMES
    ended = client.now()
    assert sim.proc.poll() is None, 'the simulator died:\n' + '\n'.join(sim.lines[-20:])
    assert not any('Traceback' in line for line in sim.lines), '\n'.join(sim.lines[-20:])
    # The partner is the client, which spoke first: PX4 keeps it, so the flood from another port
    # never diverts the telemetry. A diverted link would send the client nothing from then on (or,
    # moved back by whatever the client sends, a datagram now and then), so ATTITUDE (100 Hz;
    # 8 a second seen while the flood takes the simulator's time beside other tests) must reach it
    # in both halves of the flood, at 3 a second or more.
    client.sleep(0.5)
    middle = (started + ended) / 2.0
    times = [t for t, _ in client.by_type.get('ATTITUDE', ()) if started <= t <= ended]
    halves = (sum(1 for t in times if t < middle), sum(1 for t in times if t >= middle))
    assert all(halves) and len(times) >= 3 * (ended - started), (
        'ATTITUDE in the first / second half of %.1f s of flood: %d / %d: the telemetry went elsewhere'
        % (ended - started, halves[0], halves[1]))
    after = {name: client.read_param(name).param_value for name in before}
    assert after == before, 'parameters changed: %s -> %s' % (before, after)
    client.wait_for(lambda: client.latest['HEARTBEAT'] and client.now() - started > 0, 3.0, 'heartbeat')
    client.sleep(1.2)
    assert client.mode() == 'AUTO.LOITER' and not client.armed(), client.describe()
    start = len(client.history)
    client.send(client.mav.mission_request_list_encode(client.target, 1, MISSION))
    count = client.wait_for(lambda: next((m for _, m in client.history[start:] if m.get_type() == 'MISSION_COUNT'),
                                         None), 3.0, 'MISSION_COUNT')
    assert count.count == 0, 'no mission was uploaded by the fuzz'
    assert client.arm() == ACCEPTED, 'still answering commands'
