"""The simulated PX4's pure modules, offline: setpoint decoding, commander rules, the model."""

import math

import pytest

from offboard_py.sim import commander as cmdr
from offboard_py.sim import mission as missions
from offboard_py.sim.geo import LocalFrame
from offboard_py.sim.params import MAV_PARAM_TYPE_INT32, ParamRejected, ParamStore, decode_value, encode_value
from offboard_py.sim.vehicle import Vehicle

NAN = float('nan')
POS_YAW = 0x9F8


def make(ready_delay_s=0.0, rc=False, **overrides):
    params = ParamStore({k: v for k, v in overrides.items()})
    vehicle = Vehicle(params)
    runner = missions.MissionRunner(params, LocalFrame(47.0, 8.0, 500.0))
    return cmdr.Commander(params, vehicle, runner, 0.0, ready_delay_s=ready_delay_s, rc=rc)


def fly(c, t0, seconds, sp=None, dt=0.01):
    t = t0
    for _ in range(int(seconds / dt)):
        t += dt
        if sp is not None:
            c.on_offboard_setpoint(sp, t)
        c.tick(t, dt)
    return t


def position_setpoint(n=0.0, e=0.0, d=-2.0):
    return cmdr.offboard_setpoint(1, POS_YAW, (n, e, d), (0, 0, 0), (0, 0, 0), 0.0, 0.0, 0.0)


def test_setpoint_decoding():
    sp = position_setpoint(1, 2, -3)
    assert sp.position == (1.0, 2.0, -3.0) and all(math.isnan(v) for v in sp.velocity)
    assert sp.yaw == 0.0 and math.isnan(sp.yaw_rate)
    body = cmdr.offboard_setpoint(8, 0xDC7, (5, 5, 5), (1, 0, 0), (0, 0, 0), 0, 0, math.pi / 2)
    assert all(math.isnan(v) for v in body.position), 'BODY_NED ignores position'
    assert body.velocity[:2] == pytest.approx((0.0, 1.0)), 'body x forward, facing east'


@pytest.mark.parametrize('frame, mask, position, words', [
    (7, POS_YAW, (0, 0, -2), 'frame 7'),
    (1, POS_YAW | 512, (0, 0, -2), 'force'),
    (1, 0x1FF, (0, 0, -2), 'no position'),
    (1, POS_YAW, (0, 0, math.inf), 'infinite'),
    (1, POS_YAW, (NAN, NAN, NAN), 'no position'),
])
def test_setpoint_rejections(frame, mask, position, words):
    with pytest.raises(cmdr.SetpointRejected, match=words):
        cmdr.offboard_setpoint(frame, mask, position, (0, 0, 0), (0, 0, 0), 0, 0, 0)


def test_modes_while_disarmed_and_armed():
    c = make()
    assert c.request_mode('OFFBOARD', 1.0) == cmdr.ACCEPTED, 'any mode while disarmed'
    assert c.request_arming(True, False, 1.0) == cmdr.TEMPORARILY_REJECTED, 'no offboard signal'
    assert c.request_mode('AUTO.LOITER', 1.0) == cmdr.ACCEPTED
    assert c.request_arming(True, False, 1.0) == cmdr.ACCEPTED
    assert c.request_mode('OFFBOARD', 1.1) == cmdr.TEMPORARILY_REJECTED
    assert c.request_mode('POSCTL', 1.1) == cmdr.TEMPORARILY_REJECTED, 'no RC'
    assert c.request_mode('AUTO.MISSION', 1.1) == cmdr.TEMPORARILY_REJECTED, 'no mission'
    c.on_offboard_setpoint(position_setpoint(), 1.2)
    assert c.request_mode('OFFBOARD', 1.3) == cmdr.ACCEPTED
    for refused in ('AUTO.READY', 'AUTO.RTGS', None):
        assert c.request_mode(refused, 1.3) == cmdr.TEMPORARILY_REJECTED


def test_not_ready_then_ready():
    c = make(ready_delay_s=5.0)
    assert c.request_arming(True, False, 4.9) == cmdr.TEMPORARILY_REJECTED
    assert c.request_arming(True, True, 4.9) == cmdr.ACCEPTED, '21196 forces'


def test_offboard_takeoff_overshoot_and_hold():
    c = make()
    c.on_offboard_setpoint(position_setpoint(), 0.0)
    c.request_mode('OFFBOARD', 0.0)
    assert c.request_arming(True, False, 0.0) == cmdr.ACCEPTED
    t, highest = 0.0, 0.0
    for _ in range(1500):
        t = fly(c, t, 0.01, position_setpoint())
        highest = min(highest, c.vehicle.position[2])
    assert highest >= -2.2, 'overshoot %.2f m' % (-highest - 2)
    assert abs(c.vehicle.position[2] + 2.0) < 0.05
    assert c.takeoff_detected and c.armed


def test_failsafe_without_and_with_rc():
    for rc, expected in ((False, 'AUTO.RTL'), (True, 'POSCTL')):
        c = make(rc=rc)
        c.request_mode('OFFBOARD', 0.0)
        c.on_offboard_setpoint(position_setpoint(), 0.0)
        c.request_arming(True, False, 0.0)
        t = fly(c, 0.0, 10.0, position_setpoint())
        last = t
        while c.nav_mode == 'OFFBOARD':
            t = fly(c, t, 0.01)
        assert c.nav_mode == expected and c.failsafe
        assert t - last <= c.params['COM_OF_LOSS_T'] + 0.02
        assert c.user_mode == 'OFFBOARD', 'the intended mode stays'
        assert c.system_status() == cmdr.STATE_CRITICAL


def test_land_then_back_to_user_mode_and_auto_disarm():
    c = make(COM_DISARM_LAND=1.0)
    c.request_arming(True, False, 0.0)
    c.takeoff(NAN, 500.0, 0.0)
    t = fly(c, 0.0, 15.0)
    assert c.nav_mode == 'AUTO.LOITER' and abs(c.vehicle.height() - 2.5) < 0.35
    c.request_mode('AUTO.LAND', t)
    assert c.request_arming(False, False, t) == cmdr.DENIED, 'not landed'
    t = fly(c, t, 20.0)
    assert not c.armed and c.nav_mode == 'AUTO.LOITER'


def test_preflight_disarm():
    c = make(COM_DISARM_PRFLT=2.0)
    c.request_arming(True, False, 0.0)
    t = fly(c, 0.0, 1.9)
    assert c.armed
    fly(c, t, 0.2)
    assert not c.armed


def test_params_encoding_and_ranges():
    p = ParamStore({'COM_OF_LOSS_T': 1.0})
    assert p['COM_OF_LOSS_T'] == 1.0
    wire = encode_value(MAV_PARAM_TYPE_INT32, 4)
    assert decode_value(MAV_PARAM_TYPE_INT32, wire) == 4 and wire != 4.0
    with pytest.raises(ParamRejected, match='outside'):
        p.set('MIS_TAKEOFF_ALT', 1000.0)
    with pytest.raises(ParamRejected, match='integer'):
        p.set('COM_OBL_RC_ACT', 1.5)
    with pytest.raises(ParamRejected, match='finite'):
        p.set('MIS_TAKEOFF_ALT', NAN)
    with pytest.raises(ParamRejected, match='unknown'):
        p.set('NOPE', 1)
    assert p['MIS_TAKEOFF_ALT'] == 2.5


def test_geo_round_trip():
    f = LocalFrame(47.397742, 8.545594, 488.0)
    lat, lon, alt = f.to_global(100.0, -50.0, -10.0)
    assert f.to_local(lat, lon, alt) == pytest.approx((100.0, -50.0, -10.0))
    assert alt == pytest.approx(498.0)
