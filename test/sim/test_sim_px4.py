"""The simulated PX4 against a plain pymavlink client over UDP on 127.0.0.1 (no ROS).

Every expectation is PX4's behaviour (reference/px4-behaviour.md), not ours.
Seconds are simulated ones, on the client's clock (conftest).
"""

import csv
import math
import os
import socket
import time

from offboard_py import px4_modes
from offboard_py.dialect import (FAILURE_TYPE_OFF, FAILURE_TYPE_OK, FAILURE_UNIT_SENSOR_GYRO, MAV_CMD_INJECT_FAILURE,
                                 mavlink)
from offboard_py.testing import ports
from offboard_py.testing.mavros_typemasks import IGNORE_ACCELERATION, IGNORE_ALL_VECTORS, POSITION_AND_YAW
from offboard_py.testing.reference import load
from offboard_py.testing.sim_client import (ACCEPTED, DENIED, FAILED, TEMPORARILY_REJECTED, UNSUPPORTED, Client,
                                             SimProcess)

REPO = os.path.realpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..'))

FAST = ('--ready-delay', '1')
HOLD_FLAGS = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_AUTO_ENABLED
              | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED)
ARMED_OFFBOARD_FLAGS = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
                        | mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
NAN4 = (math.nan,) * 4
REAL32, INT32 = mavlink.MAV_PARAM_TYPE_REAL32, mavlink.MAV_PARAM_TYPE_INT32
MISSION = mavlink.MAV_MISSION_TYPE_MISSION


def fly_offboard_to_2m(client):
    client.start_stream(down=-2.0)
    client.sleep(0.5)
    assert client.set_mode('OFFBOARD') == ACCEPTED
    client.wait_mode('OFFBOARD', 2.0)
    assert client.arm() == ACCEPTED
    client.wait_armed(True, 2.0)
    # PX4 creeps over the last decimetre (P control, hover wander +-0.1 m): settled is within 0.05 m
    client.wait_for(lambda: abs(client.z() + 2.0) < 0.05, 20.0, 'z within 0.05 m of -2 m')


def test_heartbeat_identity_and_boot_state(start_sim):
    sim, client = start_sim()
    hb = client.wait_heartbeat()
    src = [m for _, m in client.history if m.get_type() == 'HEARTBEAT'][0]
    assert src.get_srcSystem() == ports.system_id(sim.instance) and src.get_srcComponent() == 1
    assert (hb.type, hb.autopilot, hb.mavlink_version) == (mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 3)
    assert hb.custom_mode == px4_modes.encode('AUTO.LOITER'), 'PX4 SITL boots in AUTO.LOITER'
    assert hb.base_mode == HOLD_FLAGS, 'AUTO modes: custom, auto, guided, stabilize; disarmed'
    assert hb.system_status == mavlink.MAV_STATE_UNINIT, 'UNINIT until the pre-flight checks pass (PX4 SITL)'
    client.wait_for(lambda: client.latest['HEARTBEAT'].system_status == mavlink.MAV_STATE_STANDBY, 7.0,
                    'STANDBY once ready (4 s)')
    t0 = client.now()
    count0 = sum(1 for _, m in client.history if m.get_type() == 'HEARTBEAT')
    client.sleep(3.0)
    count = sum(1 for t, m in client.history if m.get_type() == 'HEARTBEAT' and t >= t0) - 0
    assert 2 <= count <= 4, 'HEARTBEAT is 1 Hz, saw %d in 3 s (had %d)' % (count, count0)


def test_streams_at_px4_onboard_rates(start_sim):
    _, client = start_sim(*FAST)
    client.sleep(1.0)
    t0 = client.now()
    client.sleep(2.0)
    rates = {}
    for t, m in list(client.history):
        if t >= t0:
            rates[m.get_type()] = rates.get(m.get_type(), 0) + 0.5
    for name, hz in (('ATTITUDE', 100), ('ATTITUDE_QUATERNION', 50), ('GLOBAL_POSITION_INT', 50),
                     ('LOCAL_POSITION_NED', 30), ('HIGHRES_IMU', 50), ('ALTITUDE', 10), ('EXTENDED_SYS_STATE', 5),
                     ('SYS_STATUS', 5)):
        assert abs(rates.get(name, 0) - hz) <= hz * 0.15 + 0.5, '%s at %.1f Hz, PX4 sends %d Hz' % (
            name, rates.get(name, 0), hz)
    # SET_MESSAGE_INTERVAL: LOCAL_POSITION_NED to 5 Hz; HEARTBEAT cannot be changed (FAILED, as PX4)
    interval = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
    assert client.command(interval, mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, 200000)[0] == ACCEPTED
    assert client.command(interval, mavlink.MAVLINK_MSG_ID_HEARTBEAT, 100000)[0] == FAILED
    t1 = client.now()
    client.sleep(2.0)
    n = sum(1 for t, m in list(client.history) if t >= t1 + 0.2 and m.get_type() == 'LOCAL_POSITION_NED')
    assert 7 <= n <= 11, 'LOCAL_POSITION_NED at 5 Hz should give ~9 in 1.8 s, got %d' % n
    # REQUEST_MESSAGE: one AUTOPILOT_VERSION; an id it cannot send is DENIED (PX4 SITL)
    assert client.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)[0] == ACCEPTED
    client.wait_for(lambda: client.latest.get('AUTOPILOT_VERSION'), 2.0, 'AUTOPILOT_VERSION')
    assert client.command(mavlink.MAV_CMD_REQUEST_MESSAGE, 9999)[0] == DENIED


def test_offboard_refusals_then_acceptance(start_sim):
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    # disarmed: OFFBOARD is accepted even with no setpoints (current PX4) ...
    assert client.set_mode('OFFBOARD') == ACCEPTED
    client.wait_mode('OFFBOARD', 2.0)
    # ... but arming there without the offboard signal is refused
    assert client.arm() == TEMPORARILY_REJECTED
    assert not client.armed()
    # armed (in Hold, on the ground) and no setpoints: OFFBOARD is refused
    assert client.set_mode('AUTO.LOITER') == ACCEPTED
    assert client.arm() == ACCEPTED
    assert client.set_mode('OFFBOARD') == TEMPORARILY_REJECTED
    client.wait_mode('AUTO.LOITER', 2.0)
    client.sleep(1.2)  # a HEARTBEAT period more: the refused request changed nothing
    assert client.mode() == 'AUTO.LOITER'
    # after streaming: accepted
    client.start_stream(down=-2.0)
    client.sleep(0.3)
    assert client.set_mode('OFFBOARD') == ACCEPTED
    client.wait_mode('OFFBOARD', 2.0)


def test_command_long_set_mode_gets_two_acks(start_sim):
    _, client = start_sim(*FAST)
    custom, auto = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, px4_modes.MAIN_AUTO
    results = client.command(mavlink.MAV_CMD_DO_SET_MODE, custom, auto, px4_modes.SUB_MISSION, acks=2)
    assert results == [ACCEPTED, ACCEPTED], 'AUTO.MISSION: accepted while disarmed'
    results = client.command(mavlink.MAV_CMD_DO_SET_MODE, custom, auto, px4_modes.SUB_READY, acks=2)
    assert results == [ACCEPTED, TEMPORARILY_REJECTED], 'AUTO.READY is refused by the commander'


def test_offboard_takeoff_to_2m_and_hold(start_sim):
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    armed_at = client.now()
    fly_offboard_to_2m(client)
    climb_s = client.now() - armed_at
    samples = []
    t0 = client.now()
    while client.now() - t0 < 3.0:
        samples.append(client.z())
        client.sleep(0.05)
    highest = min(z for t, m in client.history if m.get_type() == 'LOCAL_POSITION_NED' for z in (m.z,))
    assert highest >= -2.2, 'overshoot: reached z = %.2f m (limit 0.2 m over 2 m)' % highest
    assert all(abs(z + 2.0) <= 0.1 for z in samples), 'hold left 2 +- 0.1 m: %s' % samples
    assert climb_s < 15.0
    ext = client.latest['EXTENDED_SYS_STATE']
    assert ext.landed_state == mavlink.MAV_LANDED_STATE_IN_AIR, 'IN_AIR'
    assert client.latest['HEARTBEAT'].base_mode == ARMED_OFFBOARD_FLAGS, 'armed OFFBOARD = 145 (guided=false)'
    assert client.latest['HEARTBEAT'].system_status == mavlink.MAV_STATE_ACTIVE, 'ACTIVE'
    # PX4's return estimate from 2 m over home (RtlDirect): no climb inside the cone, land 1.83 m at
    # MPC_Z_V_AUTO_DN 1.5 m/s: 1.1 x 1.2 s + RTL_TIME_MARGIN 100 s
    estimate = client.wait_for(lambda: next((m for t, m in client.history if t > t0 and
                                             m.get_type() == 'TIME_ESTIMATE_TO_TARGET'), None), 3.0,
                               'TIME_ESTIMATE_TO_TARGET in hover')
    assert 100 <= estimate.safe_return <= 102 and estimate.land == -1, estimate


def failsafe_delay(client, mode):
    """Stop the stream in OFFBOARD hover; seconds from the last setpoint to the first HEARTBEAT in `mode`
    (PX4 says a mode change in its next 1 Hz HEARTBEAT: recorded 1.93 and 1.57 s with COM_OF_LOSS_T 1,
    reference/px4-sitl-measured.md, "The flight")."""
    client.stop_stream()
    last = client.last_setpoint_s
    client.wait_for(lambda: client.mode() == mode, 3.0, mode + ' after the stream stops')
    changed = next(t for t, m in client.history if t > last and m.get_type() == 'HEARTBEAT'
                   and px4_modes.mode_string(m.base_mode, m.custom_mode) == mode)
    return changed - last


def test_failsafe_without_rc_is_return_and_lands(start_sim):
    _, client = start_sim(*FAST)
    loss_t = client.read_param('COM_OF_LOSS_T').param_value  # PX4 SITL: 1.0 s
    client.sleep(1.2)
    fly_offboard_to_2m(client)
    delay = failsafe_delay(client, 'AUTO.RTL')
    assert loss_t - 0.05 <= delay <= loss_t + 1.0 + 0.2, \
        'failsafe seen %.2f s after the last setpoint (COM_OF_LOSS_T %.1f + a HEARTBEAT period + 0.2)' % (delay, loss_t)
    cm = client.wait_for(lambda: client.current_mode() == 'AUTO.RTL' and client.latest['CURRENT_MODE'], 3.0,
                         'CURRENT_MODE (0.5 Hz) in AUTO.RTL')
    assert px4_modes.decode(cm.intended_custom_mode) == 'OFFBOARD', 'the intended mode stays OFFBOARD'
    client.wait_for(lambda: client.latest['HEARTBEAT'].system_status == mavlink.MAV_STATE_CRITICAL, 2.0,
                    'CRITICAL while in failsafe')
    # next to home: it descends at once, under control, lands and disarms
    zs = []
    client.wait_for(lambda: zs.append(client.latest['LOCAL_POSITION_NED'].vz) or not client.armed(), 20.0,
                    'disarm after landing')
    assert max(zs) <= 0.7 + 0.3, 'descended at %.2f m/s (land speed 0.7)' % max(zs)
    # landed: PX4's navigator has no return estimate any more
    landed_s = client.now()
    client.wait_for(lambda: any(t > landed_s and m.get_type() == 'TIME_ESTIMATE_TO_TARGET' and m.safe_return == 0
                                for t, m in client.history), 3.0, 'TIME_ESTIMATE_TO_TARGET 0 once landed')
    # after the disarm the vehicle is back in the mode the user chose, and stays there
    client.wait_mode('OFFBOARD', 2.0)
    client.start_stream(down=-2.0)
    client.sleep(3.0)
    assert not client.armed(), 'the vehicle must not arm by itself'


def test_failsafe_with_rc_holds_position(start_sim):
    _, client = start_sim('--rc', *FAST)
    loss_t = client.read_param('COM_OF_LOSS_T').param_value  # PX4 SITL: 1.0 s
    client.sleep(1.2)
    fly_offboard_to_2m(client)
    delay = failsafe_delay(client, 'POSCTL')  # COM_OBL_RC_ACT 0 (Position) applies with RC
    assert loss_t - 0.05 <= delay <= loss_t + 1.0 + 0.2, \
        'failsafe seen %.2f s after the last setpoint (COM_OF_LOSS_T %.1f + a HEARTBEAT period + 0.2)' % (delay, loss_t)
    t0 = client.now()
    while client.now() - t0 < 3.0:
        assert abs(client.z() + 2.0) < 0.2, 'POSCTL should hold altitude, z = %.2f' % client.z()
        client.sleep(0.1)
    assert client.armed()


def test_arming_ack_codes(start_sim):
    _, client = start_sim()  # default ready delay: 4 s, as PX4 SITL
    assert client.arm() == TEMPORARILY_REJECTED, 'not ready right after boot'
    client.wait_for(lambda: client.arm() == ACCEPTED, 8.0, 'arming accepted once ready')
    assert client.arm() == ACCEPTED, 'arming while armed is accepted'
    assert client.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, *NAN4)[0] == ACCEPTED
    client.wait_for(lambda: client.z() < -1.0, 10.0, 'climbing in AUTO.TAKEOFF')
    # PX4's Commander::disarm refuses while not (maybe) landed: TEMPORARILY_REJECTED (reference/px4-sitl-measured.md,
    # "Turn 3 recordings", section 6)
    assert client.arm(False) == TEMPORARILY_REJECTED, 'disarming in the air is refused'
    assert client.armed()
    assert client.arm(True) == ACCEPTED


def test_preflight_auto_disarm(start_sim):
    _, client = start_sim('COM_DISARM_PRFLT=2', *FAST)
    client.sleep(1.2)
    t0 = client.now()
    assert client.arm() == ACCEPTED
    client.wait_armed(True, 2.0)  # HEARTBEAT is 1 Hz: the disarm shows within 1 s of happening
    client.wait_armed(False, 4.0)
    assert 1.9 <= client.now() - t0 <= 3.5, 'COM_DISARM_PRFLT=2: disarmed after %.1f s' % (client.now() - t0)


def test_injected_failure_blocks_arming(start_sim):
    _, client = start_sim('SYS_FAILURE_EN=1', *FAST)
    client.sleep(1.2)
    assert client.command(MAV_CMD_INJECT_FAILURE, FAILURE_UNIT_SENSOR_GYRO, FAILURE_TYPE_OFF)[0] == ACCEPTED
    assert client.arm() == TEMPORARILY_REJECTED
    assert client.command(MAV_CMD_INJECT_FAILURE, FAILURE_UNIT_SENSOR_GYRO, FAILURE_TYPE_OK)[0] == ACCEPTED
    assert client.arm() == ACCEPTED


def test_takeoff_and_land_commands(start_sim):
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    assert client.arm() == ACCEPTED
    assert client.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, *NAN4)[0] == ACCEPTED
    client.wait_mode('AUTO.TAKEOFF', 2.0)
    client.wait_mode('AUTO.LOITER', 15.0)
    # PX4 completes the takeoff NAV_MC_ALT_RAD (0.8 m) short of MIS_TAKEOFF_ALT and loiters at it
    client.wait_for(lambda: abs(client.z() + 2.5) < 0.35, 5.0, 'MIS_TAKEOFF_ALT 2.5 m reached in AUTO.LOITER')
    assert client.command(mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, *NAN4)[0] == ACCEPTED
    client.wait_mode('AUTO.LAND', 2.0)
    client.wait_armed(False, 20.0)  # PX4: 12.8 s to land from 2.2 m, then COM_DISARM_LAND 2 s
    assert client.latest['EXTENDED_SYS_STATE'].landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND
    client.wait_mode('AUTO.LOITER', 2.0)  # back to the user's mode before the landing
    assert client.command(mavlink.MAV_CMD_WAYPOINT_USER_1)[0] == UNSUPPORTED


def test_param_get_set_float_and_int(start_sim):
    import struct
    _, client = start_sim(*FAST)
    value = client.read_param('MIS_TAKEOFF_ALT')
    assert value.param_type == REAL32 and value.param_value == 2.5
    client.send(client.mav.param_set_encode(client.target, 1, b'MIS_TAKEOFF_ALT', 3.5, REAL32))
    client.wait_for(lambda: client.read_param('MIS_TAKEOFF_ALT').param_value == 3.5, 3.0, 'MIS_TAKEOFF_ALT=3.5')
    value = client.read_param('COM_OBL_RC_ACT')
    assert value.param_type == INT32
    assert struct.unpack('<i', struct.pack('<f', value.param_value))[0] == 0, 'INT32 is sent bytewise'
    wire = struct.unpack('<f', struct.pack('<i', 4))[0]
    client.send(client.mav.param_set_encode(client.target, 1, b'COM_OBL_RC_ACT', wire, INT32))
    client.wait_for(lambda: struct.unpack('<i', struct.pack('<f', client.read_param('COM_OBL_RC_ACT').param_value))[0]
                    == 4, 3.0, 'COM_OBL_RC_ACT=4')
    # out of range: refused, the value in force is echoed
    client.send(client.mav.param_set_encode(client.target, 1, b'MIS_TAKEOFF_ALT', 1000.0, REAL32))
    client.sleep(0.3)
    assert client.read_param('MIS_TAKEOFF_ALT').param_value == 3.5
    # the whole list
    names = set()
    client.send(client.mav.param_request_list_encode(client.target, 1))
    client.wait_for(lambda: [names.add(m.param_id) for _, m in client.received('PARAM_VALUE')]
                    and len(names) >= client.latest['PARAM_VALUE'].param_count, 3.0, 'the full parameter list')
    assert {'MAV_TYPE', 'COM_OF_LOSS_T', 'COM_DISARM_PRFLT', 'NAV_ACC_RAD', 'MPC_Z_VEL_MAX_UP'} <= names


def upload(client, items, use_int=True):
    """Upload (command, frame, params, lat, lon, alt) tuples; return the MISSION_ACK type."""
    start = len(client.history)
    client.send(client.mav.mission_count_encode(client.target, 1, len(items), MISSION))
    sent = set()
    deadline = client.now() + 10.0
    while client.now() < deadline:
        for _, m in list(client.history[start:]):
            if m.get_type() in ('MISSION_REQUEST_INT', 'MISSION_REQUEST') and m.seq not in sent:
                sent.add(m.seq)
                cmd, frame, params, lat, lon, alt = items[m.seq]
                if use_int:
                    client.send(client.mav.mission_item_int_encode(
                        client.target, 1, m.seq, frame, cmd, 0, 1, *params, int(lat * 1e7), int(lon * 1e7), alt))
                else:
                    client.send(client.mav.mission_item_encode(
                        client.target, 1, m.seq, LEGACY_FRAME.get(frame, frame), cmd, 0, 1, *params, lat, lon, alt))
            if m.get_type() == 'MISSION_ACK':
                return m.type
        client.sleep(0.02)
    raise AssertionError('no MISSION_ACK within 10 s (simulated); vehicle: %s' % client.describe())


def download(client):
    start = len(client.history)
    client.send(client.mav.mission_request_list_encode(client.target, 1, MISSION))
    count = client.wait_for(lambda: next((m for _, m in client.history[start:] if m.get_type() == 'MISSION_COUNT'),
                                         None), 2.0, 'MISSION_COUNT').count
    items = []
    for seq in range(count):
        client.send(client.mav.mission_request_int_encode(client.target, 1, seq, MISSION))
        items.append(client.wait_for(lambda: next((m for _, m in client.history[start:]
                                                   if m.get_type() == 'MISSION_ITEM_INT' and m.seq == seq), None),
                                     2.0, 'MISSION_ITEM_INT %d' % seq))
    client.send(client.mav.mission_ack_encode(client.target, 1, mavlink.MAV_MISSION_ACCEPTED, MISSION))
    return items


# MISSION_ITEM (float) has no _INT frames
LEGACY_FRAME = {mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT}
HOME = (47.397742, 8.545594)
M_PER_DEG = 111194.93


def offset(north, east):
    return HOME[0] + north / M_PER_DEG, HOME[1] + east / (M_PER_DEG * math.cos(math.radians(HOME[0])))


def square_mission():
    wps = [offset(n, e) for n, e in ((10, 0), (10, 10), (0, 10), (0, 0))]
    frame = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    items = [(mavlink.MAV_CMD_NAV_TAKEOFF, frame, (0, 0, 0, math.nan), 0.0, 0.0, 5.0)]
    items += [(mavlink.MAV_CMD_NAV_WAYPOINT, frame, (0, 1.0, 0, math.nan), lat, lon, 5.0) for lat, lon in wps]
    items += [(mavlink.MAV_CMD_NAV_LAND, frame, (0, 0, 0, math.nan), wps[-1][0], wps[-1][1], 0.0)]
    return items


def test_mission_upload_download_clear(start_sim):
    _, client = start_sim(*FAST)
    items = square_mission()
    assert upload(client, items) == mavlink.MAV_MISSION_ACCEPTED
    got = download(client)
    assert [m.command for m in got] == [i[0] for i in items]
    assert abs(got[2].x * 1e-7 - items[2][3]) < 1e-6 and got[2].z == 5.0
    # the legacy MISSION_ITEM protocol works too
    assert upload(client, items[:3], use_int=False) == mavlink.MAV_MISSION_ACCEPTED
    assert len(download(client)) == 3
    start = len(client.history)
    client.send(client.mav.mission_clear_all_encode(client.target, 1, MISSION))
    ack = client.wait_for(lambda: next((m for _, m in client.history[start:] if m.get_type() == 'MISSION_ACK'), None),
                          2.0, 'MISSION_ACK after clear')
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED
    assert download(client) == []


def px4_landing_shift_m():
    """How far PX4 SITL's local z read at the disarm after a landing from where it read before the takeoff (its
    estimate follows a touchdown late, sim.estimator): the largest of the recorded landings, the NAV_LAND of
    px4-sitl-auto-trace.csv (0.29 m) and the two AUTO.LANDs of traces/px4-sitl-velocity-square-{1,2}.csv (0.25,
    0.47 m; ENU, t, x, y, z rows and '#state' rows t, mode, armed)."""
    rows = list(csv.DictReader(load('px4-sitl-auto-trace.csv').splitlines()))
    landing = [r for r in rows if r['phase'] == 'land']
    disarmed = next(r for r in landing if r['armed'] == '0')
    shifts = [abs(float(disarmed['z']) - float(rows[0]['z']))]
    for run in (1, 2):
        lines = [line.split(',') for line in load('traces/px4-sitl-velocity-square-%d.csv' % run).splitlines()[1:]]
        states = [(float(f[1]), f[3] == 'True') for f in lines if f[0] == '#state']
        trace = [(float(f[0]), float(f[3])) for f in lines if not f[0].startswith('#')]
        armed_s = min(t for t, armed in states if armed)
        disarmed_s = min(t for t, armed in states if t > armed_s and not armed)
        before = [z for t, z in trace if t < armed_s][-1]
        shifts.append(abs([z for t, z in trace if t <= disarmed_s][-1] - before))
    return max(shifts)


def test_four_waypoint_mission_flown_and_landed(start_sim):
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    ground_z = client.latest['LOCAL_POSITION_NED'].z
    assert upload(client, square_mission()) == mavlink.MAV_MISSION_ACCEPTED
    assert client.set_mode('AUTO.MISSION') == ACCEPTED
    assert client.arm() == ACCEPTED
    client.wait_for(lambda: {m.seq for _, m in client.received('MISSION_ITEM_REACHED')} >= {0, 1, 2, 3, 4}, 60.0,
                    'items 0..4 reached')
    client.wait_armed(False, 30.0)
    pos = client.latest['LOCAL_POSITION_NED']
    assert abs(pos.x) < 1.5 and abs(pos.y) < 1.5, 'landed at the last waypoint (home)'
    assert abs(pos.z - ground_z) <= 1.1 * px4_landing_shift_m(), 'landed: local z %.2f, %.2f before' % (pos.z, ground_z)
    # each reached once in order, then said again with MISSION_CURRENT as PX4 repeats it
    reached = list(dict.fromkeys(m.seq for _, m in client.history if m.get_type() == 'MISSION_ITEM_REACHED'))
    assert reached[:6] == [0, 1, 2, 3, 4, 5][:len(reached[:6])]


def test_two_instances_side_by_side(start_sim):
    first_sim, first = start_sim(*FAST)
    second_sim, second = start_sim(*FAST)
    src = {c.target: [m.get_srcSystem() for _, m in c.history if m.get_type() == 'HEARTBEAT'][0]
           for c in (first, second)}
    ids = [ports.system_id(sim.instance) for sim in (first_sim, second_sim)]
    assert ids[0] != ids[1] and src == {ids[0]: ids[0], ids[1]: ids[1]}
    first.sleep(1.2)
    assert first.arm() == ACCEPTED
    first.sleep(1.5)
    assert first.armed() and not second.armed()


def test_one_process_runs_a_fleet_each_vehicle_its_own_ports_id_and_place():
    """sim_px4.py --vehicles 2 (multi_uav.launch sim_process:=one): two vehicles in one loop, each on its
    instance's ports with its own system id, PX4's streams on each, spawned 3 m apart northwards as
    multi_uav.launch spawns a process each, and armed one without the other."""
    first, _ = ports.free_instances(2)
    sim = SimProcess(first, '--vehicles', '2', '--no-gcs', *FAST)
    clients = []
    try:
        clients = [Client(first, sim.clock), Client(first + 1, sim.clock)]
        for client in clients:
            client.wait_heartbeat(10.0)
        assert [c.latest['HEARTBEAT'].get_srcSystem() for c in clients] == [ports.system_id(first),
                                                                             ports.system_id(first + 1)]
        clients[0].sleep(3.0)
        rates = [len(c.by_type.get('ATTITUDE_QUATERNION', ())) for c in clients]
        assert min(rates) > 0.8 * max(rates), 'each vehicle streams as the other: %s' % rates
        lats = [c.latest['GLOBAL_POSITION_INT'].lat * 1e-7 for c in clients]
        assert abs((lats[1] - lats[0]) * 111194.9 - 3.0) < 0.2, 'the second vehicle 3 m north of the first'
        assert clients[0].arm() == ACCEPTED
        clients[0].sleep(1.0)
        assert clients[0].armed() and not clients[1].armed()
    finally:
        for client in clients:
            client.close()
        assert sim.stop() == 0, sim.output[-2000:]


def test_garbage_and_other_systems_change_nothing(start_sim):
    sim, client = start_sim(*FAST)
    # the client speaks first, as mavros does at start: PX4 keeps the first sender it hears from as
    # its partner, so garbage sent first would take the link (on PX4 SITL too)
    client.send(client.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0))
    client.sleep(1.2)
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    fcu = ('127.0.0.1', ports.fcu_port(sim.instance))
    rng = __import__('random').Random(7)
    for i in range(2000):
        raw.sendto(bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 300))), fcu)
        if i % 50 == 0:
            time.sleep(0.005)  # paced (wall seconds), so the kernel does not drop it before the parser sees it
    for magic in (0xFD, 0xFE):
        for i in range(200):
            body = bytes(rng.getrandbits(8) for _ in range(rng.randint(5, 60)))
            raw.sendto(bytes([magic]) + body, fcu)
            if i % 50 == 0:
                time.sleep(0.005)
    acks_before = len(client.acks)
    arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
    client.send(client.mav.command_long_encode(42, 1, arm, 0, 1, 0, 0, 0, 0, 0, 0))  # arm system 42
    client.send(client.mav.set_mode_encode(42, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                           px4_modes.encode('OFFBOARD')))
    client.send(client.mav.command_long_encode(client.target + 1, 1, arm, 0, 1, 0, 0, 0, 0, 0, 0))  # not us either
    client.sleep(1.5)
    assert len(client.acks) == acks_before, 'messages for other systems must not be answered'
    assert not client.armed() and client.mode() == 'AUTO.LOITER'
    assert sim.proc.poll() is None, 'the simulator died:\n' + '\n'.join(sim.lines)
    assert client.arm() == ACCEPTED, 'still answering its own system id'


def test_bad_setpoints_are_rejected(start_sim):
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    bad = [client.setpoint(0, 0, -2, frame=mavlink.MAV_FRAME_LOCAL_OFFSET_NED),
           # a force: FORCE_SET with the acceleration fields in use
           client.setpoint(0, 0, -2, type_mask=POSITION_AND_YAW & ~IGNORE_ACCELERATION
                           | mavlink.POSITION_TARGET_TYPEMASK_FORCE_SET),
           client.setpoint(0, 0, -2, type_mask=IGNORE_ALL_VECTORS),  # nothing used
           client.setpoint(0, 0, math.inf)]
    for _ in range(30):
        for msg in bad:
            client.send(msg)
        client.sleep(0.05)
    assert client.set_mode('OFFBOARD') == ACCEPTED  # disarmed: accepted anyway
    assert client.arm() == TEMPORARILY_REJECTED, 'rejected setpoints must not count as an offboard signal'


def test_force_bit_with_acceleration_ignored_is_a_position_setpoint(start_sim):
    """Measured on PX4 SITL (px4-sitl-measured.md, Answers): taken as a normal position setpoint."""
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    with_force = client.setpoint(0, 0, -2, type_mask=POSITION_AND_YAW | mavlink.POSITION_TARGET_TYPEMASK_FORCE_SET)
    for _ in range(10):
        client.send(with_force)
        client.sleep(0.05)
    assert client.set_mode('OFFBOARD') == ACCEPTED
    assert client.arm() == ACCEPTED, 'the setpoint counts as the offboard signal'


def test_rejects_bad_command_line():
    import subprocess
    import sys
    script = os.path.join(REPO, 'scripts', 'sim_px4.py')
    for args, words in ((['NOT_A_PARAM=1'], 'unknown parameter'), (['COM_OF_LOSS_T=-3'], 'COM_OF_LOSS_T'),
                        (['--home', '95,0,0'], 'home'), (['-i', '-1'], 'instance'), (['--vehicles', '0'], 'vehicles'),
                        (['-i', '98', '--vehicles', '3'], 'instances end at 99'),
                        (['--vehicles', '2', '--local-port', '15000'], '--local-port')):
        out = subprocess.run([sys.executable, script] + args, capture_output=True, text=True, timeout=20)
        assert out.returncode != 0, args
        assert words in out.stdout + out.stderr, (args, out.stdout + out.stderr)
        assert 'Traceback' not in out.stderr


def test_ack_is_addressed_to_the_sender(start_sim):
    """COMMAND_ACK goes back to the sender's system and component (and unknown commands are UNSUPPORTED)."""
    _, client = start_sim(*FAST)
    unsupported = mavlink.MAV_CMD_WAYPOINT_USER_1
    client.send(client.mav.command_long_encode(client.target, 1, unsupported, 0, 0, 0, 0, 0, 0, 0, 0))
    ack = client.wait_for(lambda: next((a for _, a in client.acks if a.command == unsupported), None), 2.0, 'ACK')
    assert (ack.target_system, ack.target_component) == (255, mavlink.MAV_COMP_ID_MISSIONPLANNER)


# The tutorial flight on real PX4 SITL (reference/px4-sitl-measured.md: arm -> z 1.9 m 7.41 and 7.48 s,
# "Turn 3 recordings" section 2: 6.76 and 8.51 s), its disarm 1.9 s after the arm (section 6:
# TEMPORARILY_REJECTED), and the failsafe's gimbal commands on the onboard link (reference/conversations:
# COMMAND_LONG 1001, 1000, 1001 to system 1 component 0, the first repeated with confirmation 1-3)
ARM_TO_1_9_M_S = (6.76, 8.51)


def test_tutorial_takeoff_timing_disarm_refused_while_climbing_and_failsafe_gimbal_commands(start_sim):
    sim, client = start_sim('--ready-delay', '4')
    client.start_stream(down=-2.0)
    client.wait_for(lambda: client.latest.get('HEARTBEAT') and client.latest['HEARTBEAT'].system_status
                    == mavlink.MAV_STATE_STANDBY, 8.0, 'pre-flight checks passing')
    assert client.set_mode('OFFBOARD') == ACCEPTED
    client.sleep(1.0)
    t_arm = client.now()
    assert client.arm() == ACCEPTED
    client.sleep(max(0.0, t_arm + 1.9 - client.now()))
    assert client.arm(False) == TEMPORARILY_REJECTED, 'PX4: not landed 1.9 s into an OFFBOARD takeoff'
    client.wait_for(lambda: client.z() <= -1.9, 15.0, 'z 1.9 m up')
    took = client.now() - t_arm
    print('arm -> 1.9 m: %.2f s' % took)
    assert ARM_TO_1_9_M_S[0] * 0.9 <= took <= ARM_TO_1_9_M_S[1] * 1.1, 'arm -> 1.9 m %.2f s, PX4 %s' % (
        took, ARM_TO_1_9_M_S)
    client.sleep(3.0)
    client.stop_stream()
    stopped = client.now()
    client.wait_for(lambda: len([m for _, m in client.received('COMMAND_LONG')
                                 if m.command == mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE]) >= 5, 6.0,
                    'the return\'s gimbal commands and their repeats')
    got = [(round(t - stopped, 2), m.command, m.confirmation, m.target_system, m.target_component)
           for t, m in client.received('COMMAND_LONG')]
    assert [g[1:] for g in got[:6]] == [
        (mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 0, sim.system_id, 0),
        (mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, 0, sim.system_id, 0),
        (mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 0, sim.system_id, 0),
        (mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 1, sim.system_id, 0),
        (mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 2, sim.system_id, 0),
        (mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 3, sim.system_id, 0)], got
    # recorded 1.29-1.37 s after the last setpoint (the stream stops within one 20 Hz period of `stopped`)
    assert 1.29 * 0.9 - 0.05 <= got[0][0] <= 1.37 * 1.1, got
    texts = [m.text for _, m in client.received('STATUSTEXT')]
    # none on the onboard link, where no ground station's HEARTBEAT came: PX4 sends STATUSTEXT only to one
    assert texts == [], texts


def hover_thrust_plus(client, extra):
    """SET_ATTITUDE_TARGET: level, heading north, collective MPC_THR_HOVER (0.5) + `extra`."""
    rates_ignored = (mavlink.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE
                     | mavlink.ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE
                     | mavlink.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE)
    return lambda: client.mav.set_attitude_target_encode(0, client.target, 1, rates_ignored, [1.0, 0.0, 0.0, 0.0],
                                                         0.0, 0.0, 0.0, 0.5 + extra)


def test_attitude_setpoints_are_the_offboard_signal_and_are_flown(start_sim):
    """PX4 takes SET_ATTITUDE_TARGET as the offboard signal (mavros setpoint_raw/attitude and
    setpoint_attitude) and flies the attitude and collective thrust without its position
    controller: above hover thrust the vehicle climbs, below it sinks. A message with neither an
    attitude nor roll and pitch rates gives no signal, as on PX4."""
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    neither = lambda: client.mav.set_attitude_target_encode(  # noqa: E731
        0, client.target, 1, mavlink.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE
        | mavlink.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE, [1.0, 0.0, 0.0, 0.0], 0.1, 0.0, 0.0, 0.5)
    client.start_stream(message=neither)
    client.sleep(0.5)
    assert client.set_mode('OFFBOARD') == ACCEPTED  # disarmed: accepted without the signal, as PX4
    client.wait_mode('OFFBOARD', 2.0)
    assert client.arm() == TEMPORARILY_REJECTED, 'no attitude and no roll rate: no signal'
    client.start_stream(message=hover_thrust_plus(client, 0.1))
    client.sleep(0.5)
    assert client.arm() == ACCEPTED
    client.wait_armed(True, 2.0)
    client.wait_for(lambda: client.z() < -3.0, 15.0, 'a climb above 3 m at hover thrust + 0.1')
    client.start_stream(message=hover_thrust_plus(client, -0.1))
    top = client.z()
    client.wait_for(lambda: client.z() > top + 0.5, 10.0, 'a descent at hover thrust - 0.1')
    assert client.latest['HEARTBEAT'].custom_mode == px4_modes.encode('OFFBOARD')
    client.stop_stream()


def test_global_setpoints_are_the_offboard_signal_and_are_flown(start_sim):
    """SET_POSITION_TARGET_GLOBAL_INT (mavros setpoint_raw/global): a position 3 m north of home at
    2.5 m above it (GLOBAL_RELATIVE_ALT_INT), flown in OFFBOARD as a local one; another frame is
    refused and gives no signal. The local z is PX4's arithmetic, home's altitude minus 2.5 m minus
    the origin's: -2.5 m less home's local z (which PX4 adds with the wrong sign)."""
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    home = client.wait_for(lambda: client.latest.get('GLOBAL_POSITION_INT'), 5.0, 'GLOBAL_POSITION_INT')
    north_deg = 3.0 / 111194.9  # 3 m of latitude on a 6371 km sphere
    lat, lon = home.lat + int(round(north_deg * 1e7)), home.lon

    def target(frame):
        return lambda: client.mav.set_position_target_global_int_encode(
            0, client.target, 1, frame, POSITION_AND_YAW, lat, lon, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    client.start_stream(message=target(mavlink.MAV_FRAME_LOCAL_NED))
    client.sleep(0.5)
    assert client.set_mode('OFFBOARD') == ACCEPTED  # disarmed: accepted without the signal, as PX4
    client.wait_mode('OFFBOARD', 2.0)
    assert client.arm() == TEMPORARILY_REJECTED, 'frame LOCAL_NED is not a global frame: no signal'
    client.start_stream(message=target(mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT))
    client.sleep(0.5)
    assert client.arm() == ACCEPTED
    client.wait_armed(True, 2.0)
    client.sleep(2.1)  # HOME_POSITION (set again at arming) is sent at 0.5 Hz
    down = -client.latest['HOME_POSITION'].z - 2.5
    client.wait_for(lambda: abs(client.latest['LOCAL_POSITION_NED'].x - 3.0) < 0.3 and abs(client.z() - down) < 0.3,
                    25.0, 'the vehicle 3 m north at local z %.2f m (within 0.3 m)' % down)
    client.stop_stream()


def test_reposition_flies_to_a_global_position_in_loiter(start_sim):
    """MAV_CMD_DO_REPOSITION as MAVSDK's goto_location sends it (COMMAND_INT, MAV_FRAME_GLOBAL_INT,
    param2 bit 0 asking for the mode change): ACCEPTED, AUTO.LOITER, flown to 6 m north at 4 m
    above home's AMSL altitude, held there. Without bit 0 PX4 answers UNSUPPORTED."""
    _, client = start_sim(*FAST)
    client.sleep(1.2)
    assert client.arm() == ACCEPTED
    assert client.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, *NAN4)[0] == ACCEPTED
    client.wait_mode('AUTO.LOITER', 15.0)
    home = client.wait_for(lambda: client.latest.get('HOME_POSITION'), 3.0, 'HOME_POSITION')
    lat = home.latitude + int(round(6.0 / 111194.9 * 1e7))  # 6 m north on a 6371 km sphere
    alt = home.altitude / 1000.0 + 4.0
    frame = mavlink.MAV_FRAME_GLOBAL_INT
    nan4 = (-1.0, 0.0, 0.0, math.nan)
    assert client.command_int(mavlink.MAV_CMD_DO_REPOSITION, frame, nan4, lat, home.longitude, alt) == UNSUPPORTED
    assert client.command_int(mavlink.MAV_CMD_DO_REPOSITION, frame, (-1.0, 1.0, 0.0, math.nan), lat, home.longitude,
                              alt) == ACCEPTED
    client.wait_for(lambda: abs(client.latest['LOCAL_POSITION_NED'].x - home.x - 6.0) < 0.5
                    and abs(client.z() - (home.z - 4.0)) < 0.3, 20.0, '6 m north of home, 4 m above it')
    assert client.mode() == 'AUTO.LOITER'
