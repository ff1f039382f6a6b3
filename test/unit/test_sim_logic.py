"""The simulated PX4's pure modules, offline: setpoint decoding, commander rules, navigator, the model."""

import math

import pytest

from offboard_py import param_codec
from offboard_py.dialect import ARM_DISARM_FORCE_MAGIC, mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import offboard_input
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.param_store import ParamRejected, ParamStore
from offboard_py.testing.mavros_typemasks import IGNORE_ALL_VECTORS, IGNORE_VELOCITY, POSITION_AND_YAW, VELOCITY_ONLY
from offboard_py.testing.reference import load, px4_param

NAN = float('nan')
M = mavlink
POS_YAW = POSITION_AND_YAW
ACCEPTED, TEMPORARILY_REJECTED, DENIED = M.MAV_RESULT_ACCEPTED, M.MAV_RESULT_TEMPORARILY_REJECTED, M.MAV_RESULT_DENIED


def make(ready_delay_s=0.0, rc=False, **overrides):
    params = ParamStore({k: v for k, v in overrides.items()})
    return Flight(params, GeoOrigin(47.0, 8.0, 500.0), 0.0, ready_delay_s=ready_delay_s, rc=rc)


def fly(f, t0, seconds, sp=None, dt=0.01):
    t = t0
    for _ in range(int(seconds / dt)):
        t += dt
        if sp is not None:
            f.on_offboard_setpoint(sp, t)
        f.step(t, dt)
    return t


def position_setpoint(n=0.0, e=0.0, d=-2.0, mask=POS_YAW):
    return offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, mask, (n, e, d), (0, 0, 0), (0, 0, 0), 0.0, 0.0,
                                            0.0)


def test_setpoint_decoding():
    sp = position_setpoint(1, 2, -3)
    assert sp.position == (1.0, 2.0, -3.0) and all(math.isnan(v) for v in sp.velocity)
    assert sp.yaw == 0.0 and math.isnan(sp.yaw_rate)
    body = offboard_input.offboard_setpoint(M.MAV_FRAME_BODY_NED, VELOCITY_ONLY, (5, 5, 5), (1, 0, 0), (0, 0, 0),
                                            0, 0, math.pi / 2)
    assert all(math.isnan(v) for v in body.position), 'BODY_NED ignores position'
    assert body.velocity[:2] == pytest.approx((0.0, 1.0)), 'body x forward, facing east'


def test_body_ned_drops_a_vector_with_any_axis_ignored():
    """PX4's receiver (BODY_NED): one velocity axis ignored drops the whole velocity, so a setpoint
    with only vx and vy is no setpoint at all, where LOCAL_NED flies the two axes it has."""
    vz_ignored = VELOCITY_ONLY | M.POSITION_TARGET_TYPEMASK_VZ_IGNORE
    with pytest.raises(offboard_input.SetpointRejected, match='no position, velocity or acceleration'):
        offboard_input.offboard_setpoint(M.MAV_FRAME_BODY_NED, vz_ignored, (0, 0, 0), (0.5, 0, 0), (0, 0, 0), 0, 0, 0.0)
    local = offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, vz_ignored, (0, 0, 0), (0.5, 0, 0), (0, 0, 0), 0,
                                             0, 0.0)
    assert local.velocity[:2] == (0.5, 0.0) and math.isnan(local.velocity[2])


GLOBAL_ORIGIN = GeoOrigin(47.0, 8.0, 500.0)


def global_setpoint(frame, alt, mask=POS_YAW, home_amsl=500.4, origin=GLOBAL_ORIGIN):
    return offboard_input.global_setpoint(frame, mask, int(47.0 * 1e7) + 270, int(8.0 * 1e7), alt, (0, 0, 0),
                                          (0, 0, 0), 0.0, 0.0, origin, home_amsl)


def test_global_setpoint_altitudes_as_px4_computes_them():
    """SET_POSITION_TARGET_GLOBAL_INT: north of the origin by 270e-7 deg (3.0 m), and the local z by
    PX4's own arithmetic: the origin's altitude minus an AMSL one; home's minus a relative one minus
    the origin's (PX4's receiver: -alt when home is at the origin's height, and home's offset with
    the sign turned when it is not)."""
    sp = global_setpoint(M.MAV_FRAME_GLOBAL_INT, 503.0)
    assert sp.position == pytest.approx((3.0, 0.0, -3.0), abs=0.01)
    assert global_setpoint(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 2.5, home_amsl=500.0).position[2] == pytest.approx(-2.5)
    assert global_setpoint(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 2.5, home_amsl=500.4).position[2] == pytest.approx(-2.1)


@pytest.mark.parametrize('frame, alt, kwargs, words', [
    (M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, 2.0, {}, 'frame 11'),
    (M.MAV_FRAME_LOCAL_NED, 2.0, {}, 'frame 1'),
    (M.MAV_FRAME_GLOBAL_INT, NAN, {}, 'not a number'),
    (M.MAV_FRAME_GLOBAL_INT, 2.0, {'origin': None}, 'no global position yet'),
])
def test_global_setpoints_refused(frame, alt, kwargs, words):
    with pytest.raises(offboard_input.SetpointRejected, match=words):
        global_setpoint(frame, alt, **kwargs)


def test_global_setpoint_velocity_only_needs_no_position():
    sp = global_setpoint(M.MAV_FRAME_LOCAL_NED, NAN, mask=VELOCITY_ONLY, origin=None)
    assert all(math.isnan(v) for v in sp.position) and sp.velocity == (0.0, 0.0, 0.0)


def test_attitude_setpoint():
    half = math.sqrt(0.5)
    sp = offboard_input.attitude_setpoint(0, (2 * half, 0.0, 0.0, 2 * half), 0.6)  # not unit: normalised
    assert sp.attitude == pytest.approx((half, 0.0, 0.0, half)) and sp.yaw == pytest.approx(math.pi / 2)
    assert sp.thrust == 0.6 and all(math.isnan(v) for v in sp.position + sp.velocity)
    no_rates = (M.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE | M.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE)
    for mask, q, thrust, words in [(no_rates, (1, 0, 0, 0), 0.5, 'neither an attitude nor'),
                                   (0, (0, 0, 0, 0), 0.5, 'all zero'), (0, (NAN, 0, 0, 1), 0.5, 'not finite'),
                                   (0, (1, 0, 0, 0), 1.5, 'outside 0..1'), (0, (1, 0, 0, 0), NAN, 'outside 0..1'),
                                   (32, (1, 0, 0, 0), 0.5, 'thrust_body')]:
        with pytest.raises(offboard_input.SetpointRejected, match=words):
            offboard_input.attitude_setpoint(mask, q, thrust)


def test_body_rate_setpoints():
    """Attitude ignored, roll and pitch rates given: PX4 flies the rates (its body_rates offboard mode);
    the yaw rate is 0 when ignored; a NaN rate is refused."""
    rates_only = M.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE
    sp = offboard_input.attitude_setpoint(rates_only | M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE,
                                          (1, 0, 0, 0), 0.55, (0.1, -0.2, 0.3))
    assert sp.rates == (0.1, -0.2, 0.0) and sp.thrust == 0.55 and sp.attitude is None
    with pytest.raises(offboard_input.SetpointRejected, match='not finite'):
        offboard_input.attitude_setpoint(rates_only, (1, 0, 0, 0), 0.5, (NAN, 0.0, 0.0))


def test_body_rates_flown_frd():
    """Armed in OFFBOARD on body rates, facing north: a positive roll rate (FRD: right side down)
    tilts the thrust to the east and the vehicle goes east; a positive pitch rate (nose up) sends it
    south; a yaw rate turns it."""
    mask = M.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE

    def rates(roll=0.0, pitch=0.0, yaw=0.0, thrust=0.6):
        return offboard_input.attitude_setpoint(mask, (1, 0, 0, 0), thrust, (roll, pitch, yaw))
    for axis, sign, turn in ((1, 1.0, {'roll': 0.4}), (0, -1.0, {'pitch': 0.4})):
        f = make()
        t = fly(f, 0.0, 0.5, rates())
        assert f.request_mode('OFFBOARD', t) == ACCEPTED and f.request_arming(True, False, t) == ACCEPTED
        t = fly(f, t, 3.0, rates())
        assert f.vehicle.position[2] < f.vehicle.ground_z - 0.5, 'climbing at thrust 0.6'
        start = list(f.vehicle.position)
        t = fly(f, t, 0.5, rates(**turn))
        t = fly(f, t, 1.5, rates())
        moved = f.vehicle.position[axis] - start[axis]
        assert sign * moved > 0.3, (turn, moved)
    yaw0 = f.vehicle.yaw
    fly(f, t, 1.0, rates(yaw=0.5))
    assert f.vehicle.yaw - yaw0 == pytest.approx(0.5, abs=0.05)


def test_attitude_setpoint_flown_without_the_position_controller():
    """Armed in OFFBOARD on attitude setpoints: spool-up first, then above hover thrust it climbs;
    a 10 deg pitch forward (NED/FRD: nose down) moves it north."""
    f = make()
    level = offboard_input.attitude_setpoint(0, (1.0, 0.0, 0.0, 0.0), 0.6)
    t = fly(f, 0.0, 0.5, level)
    assert f.request_mode('OFFBOARD', t) == ACCEPTED and f.request_arming(True, False, t) == ACCEPTED
    t = fly(f, t, 1.0, level)
    assert f.vehicle.position[2] == pytest.approx(f.vehicle.ground_z), 'still spooling up (COM_SPOOLUP_TIME 1 s)'
    t = fly(f, t, 3.0, level)
    assert f.vehicle.position[2] < f.vehicle.ground_z - 1.0, 'climbing at 0.6 > MPC_THR_HOVER 0.5'
    pitch = math.radians(-10.0) / 2
    forward = offboard_input.attitude_setpoint(0, (math.cos(pitch), 0.0, math.sin(pitch), 0.0), 0.55)
    north = f.vehicle.position[0]
    fly(f, t, 2.0, forward)
    assert f.vehicle.position[0] > north + 0.5


def test_force_bit_with_acceleration_ignored_is_a_position_setpoint():
    """Measured on PX4 SITL (px4-sitl-measured.md, Answers): taken as a normal position setpoint."""
    sp = position_setpoint(mask=POS_YAW | M.POSITION_TARGET_TYPEMASK_FORCE_SET)
    assert sp.position == (0.0, 0.0, -2.0) and all(math.isnan(v) for v in sp.acceleration)


@pytest.mark.parametrize('frame, mask, position, words', [
    (M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POS_YAW, (0, 0, -2), 'frame 6'),
    (M.MAV_FRAME_LOCAL_NED, M.POSITION_TARGET_TYPEMASK_FORCE_SET | IGNORE_VELOCITY, (0, 0, -2), 'force'),
    (M.MAV_FRAME_LOCAL_NED, IGNORE_ALL_VECTORS, (0, 0, -2), 'no position'),
    (M.MAV_FRAME_LOCAL_NED, POS_YAW, (0, 0, math.inf), 'infinite'),
    (M.MAV_FRAME_LOCAL_NED, POS_YAW, (NAN, NAN, NAN), 'no position'),
])
def test_setpoint_rejections(frame, mask, position, words):
    with pytest.raises(offboard_input.SetpointRejected, match=words):
        offboard_input.offboard_setpoint(frame, mask, position, (0, 0, 0), (0, 0, 0), 0, 0, 0)


def test_modes_while_disarmed_and_armed():
    c = make()
    assert c.request_mode('OFFBOARD', 1.0) == ACCEPTED, 'any mode while disarmed'
    assert c.request_arming(True, False, 1.0) == TEMPORARILY_REJECTED, 'no offboard signal'
    assert c.request_mode('AUTO.LOITER', 1.0) == ACCEPTED
    assert c.request_arming(True, False, 1.0) == ACCEPTED
    assert c.request_mode('OFFBOARD', 1.1) == TEMPORARILY_REJECTED
    assert c.request_mode('POSCTL', 1.1) == TEMPORARILY_REJECTED, 'no RC'
    assert c.request_mode('AUTO.MISSION', 1.1) == TEMPORARILY_REJECTED, 'no mission'
    c.on_offboard_setpoint(position_setpoint(), 1.2)
    assert c.request_mode('OFFBOARD', 1.3) == ACCEPTED
    for refused in ('AUTO.READY', 'AUTO.RTGS', None):
        assert c.request_mode(refused, 1.3) == TEMPORARILY_REJECTED


def test_not_ready_then_ready():
    c = make(ready_delay_s=5.0)
    assert c.request_arming(True, False, 4.9) == TEMPORARILY_REJECTED
    assert c.request_arming(True, True, 4.9) == ACCEPTED, '21196 forces'


def test_offboard_takeoff_overshoot_and_hold():
    c = make()
    c.on_offboard_setpoint(position_setpoint(), 0.0)
    c.request_mode('OFFBOARD', 0.0)
    assert c.request_arming(True, False, 0.0) == ACCEPTED
    t, highest = 0.0, 0.0
    for _ in range(1500):
        t = fly(c, t, 0.01, position_setpoint())
        highest = min(highest, c.vehicle.position[2])
    assert highest >= -2.2, 'overshoot %.2f m' % (-highest - 2)
    assert abs(c.vehicle.position[2] + 2.0) < 0.05
    assert c.commander.takeoff_detected and c.commander.armed


def test_failsafe_without_and_with_rc():
    for rc, expected in ((False, 'AUTO.RTL'), (True, 'POSCTL')):
        c = make(rc=rc)
        c.request_mode('OFFBOARD', 0.0)
        c.on_offboard_setpoint(position_setpoint(), 0.0)
        c.request_arming(True, False, 0.0)
        t = fly(c, 0.0, 10.0, position_setpoint())
        last = t
        while c.commander.nav_mode == 'OFFBOARD':
            t = fly(c, t, 0.01)
        assert c.commander.nav_mode == expected and c.commander.failsafe
        assert t - last <= c.params['COM_OF_LOSS_T'] + 0.02
        assert c.commander.user_mode == 'OFFBOARD', 'the intended mode stays'
        assert c.commander.system_status(t) == M.MAV_STATE_CRITICAL


def test_land_then_back_to_user_mode_and_auto_disarm():
    c = make(COM_DISARM_LAND=1.0)
    c.request_arming(True, False, 0.0)
    c.takeoff(NAN, 500.0, 0.0)
    t = fly(c, 0.0, 15.0)
    assert c.commander.nav_mode == 'AUTO.LOITER' and abs(c.vehicle.height() - 2.5) < 0.35
    c.request_mode('AUTO.LAND', t)
    assert c.request_arming(False, False, t) == TEMPORARILY_REJECTED, 'not landed (PX4: TRANSITION_DENIED)'
    t = fly(c, t, 20.0)
    assert not c.commander.armed and c.commander.nav_mode == 'AUTO.LOITER'


def test_preflight_disarm():
    c = make(COM_DISARM_PRFLT=2.0)
    c.request_arming(True, False, 0.0)
    t = fly(c, 0.0, 1.9)
    assert c.commander.armed
    fly(c, t, 0.2)
    assert not c.commander.armed


def test_params_encoding_and_ranges():
    p = ParamStore({'COM_OF_LOSS_T': 1.0})
    assert p['COM_OF_LOSS_T'] == 1.0
    wire = param_codec.encode(M.MAV_PARAM_TYPE_INT32, 4)
    assert param_codec.decode(M.MAV_PARAM_TYPE_INT32, wire) == 4 and wire != 4.0
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
    f = GeoOrigin(47.397742, 8.545594, 488.0)
    lat, lon, alt = f.to_global(100.0, -50.0, -10.0)
    assert f.to_local(lat, lon, alt) == pytest.approx((100.0, -50.0, -10.0))
    assert alt == pytest.approx(498.0)


def test_takeoff_events_are_typed_and_in_order():
    f = make()
    assert f.request_arming(True, False, 0.0) == ACCEPTED
    assert f.takeoff(NAN, 500.0, 0.0) == ACCEPTED
    early = f.take_events()
    assert ev.ArmingChanged(True, 'commanded') in early and ev.ModeChanged('AUTO.TAKEOFF', False) in early
    fly(f, 0.0, 15.0)
    later = f.take_events()
    assert ev.StatusText(M.MAV_SEVERITY_INFO, 'Takeoff complete') in later
    assert later.index(ev.ModeChanged('AUTO.LOITER', False)) > later.index(
        ev.StatusText(M.MAV_SEVERITY_INFO, 'Takeoff complete'))
    st = f.status(15.0)
    assert (st.nav_mode, st.armed, st.landed_state) == ('AUTO.LOITER', True, M.MAV_LANDED_STATE_IN_AIR)
    assert st.height == pytest.approx(2.5, abs=0.35)


def test_takeoff_altitude_from_the_command():
    f = make()
    f.request_arming(True, False, 0.0)
    f.takeoff(505.0, 500.0, 0.0)  # AMSL 505 m over a home at 500 m: 5 m up
    fly(f, 0.0, 20.0)
    assert f.commander.nav_mode == 'AUTO.LOITER' and f.vehicle.height() == pytest.approx(5.0, abs=0.35)


def test_takeoff_below_the_vehicle_says_already_higher_and_stays():
    """navigator/takeoff.cpp set_takeoff_position: an altitude below the vehicle is taken as where it is, with
    "Already higher than takeoff altitude"; PX4 does not descend and, on the ground, does not take off
    (reference/px4-sitl-measured.md, "Turn 5": mavros's cmd/takeoff passes AMSL, 2.5 m). NaN is MIS_TAKEOFF_ALT
    above the vehicle, with "Using default takeoff altitude"."""
    f = make()
    assert f.request_arming(True, False, 0.0) == ACCEPTED
    f.take_events()
    assert f.takeoff(2.5, 500.0, 0.0) == ACCEPTED  # AMSL 2.5 m under a home at 500 m
    said = [e for e in f.take_events() if isinstance(e, ev.StatusText)]
    assert ev.StatusText(M.MAV_SEVERITY_CRITICAL, 'Already higher than takeoff altitude\t') in said
    fly(f, 0.0, 8.0)
    assert f.vehicle.landed and f.vehicle.height() < 0.05, 'stayed on the ground'
    in_air = make()
    in_air.request_arming(True, False, 0.0)
    in_air.takeoff(510.0, 500.0, 0.0)
    t = fly(in_air, 0.0, 25.0)
    assert in_air.takeoff(505.0, 500.0, t) == ACCEPTED, 'asked for 5 m while at 10 m'
    t = fly(in_air, t, 10.0)
    assert in_air.vehicle.height() == pytest.approx(10.0, abs=0.5), 'did not descend'
    default = make()
    default.request_arming(True, False, 0.0)
    default.take_events()
    default.takeoff(NAN, 500.0, 0.0)
    assert ev.StatusText(M.MAV_SEVERITY_INFO, 'Using default takeoff altitude: %.1f m\t' % px4_param('MIS_TAKEOFF_ALT')) \
        in default.take_events()


def test_mission_items_reached_in_order():
    from offboard_py.sim.mavlink.mission_manager import Item
    f = make()
    local = M.MAV_FRAME_LOCAL_NED
    f.load_mission([Item(local, M.MAV_CMD_NAV_TAKEOFF, 1, 0, 0, 0, NAN, 0.0, 0.0, -3.0),
                    Item(local, M.MAV_CMD_NAV_WAYPOINT, 1, 0, 1.0, 0, NAN, 5.0, 0.0, -3.0),
                    Item(local, M.MAV_CMD_NAV_LAND, 1, 0, 0, 0, NAN, 5.0, 0.0, 0.0)])
    assert f.request_mode('AUTO.MISSION', 0.0) == ACCEPTED
    assert f.request_arming(True, False, 0.0) == ACCEPTED
    f.take_events()
    fly(f, 0.0, 40.0)
    reached = [e.seq for e in f.take_events() if isinstance(e, ev.ItemReached)]
    assert reached == [0, 1, 2]
    assert f.vehicle.position[0] == pytest.approx(5.0, abs=1.0) and f.vehicle.landed


def test_current_mode_carries_the_standard_mode():
    from offboard_py.sim.mavlink.messages import TelemetryBuilder
    f = make()
    builder = TelemetryBuilder(M.MAVLink(None), GeoOrigin(47.0, 8.0, 500.0), f.params)
    # PX4's numbers on the wire (reference/px4-sitl-measured.md, "Turn 3 recordings", section 3: MISSION 6,
    # LAND 7, TAKEOFF 8; pymavlink 2.4.49's development enum numbers these one higher)
    for mode, standard, custom in (('AUTO.MISSION', 6, 0x04040000), ('AUTO.LAND', 7, 0x06040000),
                                   ('AUTO.TAKEOFF', 8, 0x02040000), ('OFFBOARD', 0, 0x00060000),
                                   ('AUTO.LOITER', 0, 0x03040000)):
        f.request_mode(mode, 1.0)
        msg = builder.current_mode(f.status(1.0))
        assert (msg.standard_mode, msg.custom_mode, msg.intended_custom_mode) == (standard, custom, custom), mode


def test_force_disarm_magic_in_the_air():
    f = make()
    f.on_offboard_setpoint(position_setpoint(), 0.0)
    f.request_mode('OFFBOARD', 0.0)
    f.request_arming(True, False, 0.0)
    t = fly(f, 0.0, 8.0, position_setpoint())
    assert f.request_arming(False, False, t) == TEMPORARILY_REJECTED
    assert f.request_arming(False, True, t) == ACCEPTED and not f.commander.armed
    assert ARM_DISARM_FORCE_MAGIC == 21196


# -- PX4's flight model: the pieces the flight fit (test/sim/test_flight_fit.py) rests on ---------

def test_land_speeds_are_px4s():
    from offboard_py.sim.flyer import land_speed
    p = ParamStore()
    assert land_speed(p, 20.0) == p['MPC_Z_V_AUTO_DN'] == 1.5
    assert land_speed(p, 7.5) == pytest.approx((1.5 + 0.7) / 2), 'blends between MPC_LAND_ALT1 and ALT2'
    assert land_speed(p, 3.0) == p['MPC_LAND_SPEED'] == 0.7
    assert land_speed(p, 0.5) == p['MPC_LAND_CRWL'] == 0.3, 'crawl below MPC_LAND_ALT3'


def test_rtl_return_altitude_with_the_cone():
    from offboard_py.sim.rtl import rtl_return_height
    p = ParamStore()
    assert rtl_return_height(p, 100.0) == 30.0, 'RTL_RETURN_ALT beyond RTL_MIN_DIST'
    assert rtl_return_height(p, 6.0) == pytest.approx(6.0), 'inside RTL_MIN_DIST: the 45 deg cone'
    assert rtl_return_height(p, 3.0) == pytest.approx(4.0), 'at least 2 NAV_ACC_RAD outside the acceptance radius'
    assert rtl_return_height(p, 1.0) == pytest.approx(2.0), 'inside it: 2 x the distance'
    assert rtl_return_height(ParamStore({'RTL_CONE_ANG': 0}), 6.0) == 30.0, 'no cone'


def test_trajectory_brakes_early_and_passes_corners_at_px4s_speed():
    from offboard_py.sim.trajectory import corner_speed, speed_from_distance
    p = ParamStore()
    # PX4's computeMaxSpeedFromDistance with MPC_JERK_AUTO 4, MPC_ACC_HOR 3: slow over the last metres
    assert speed_from_distance(4.0, 3.0, 2.0, 0.0) == pytest.approx(1.18, abs=0.01)
    assert speed_from_distance(4.0, 3.0, 0.0, 1.0) == 1.0
    right_angle = corner_speed(p, (0.0, 0.0, -10.0), (15.0, 0.0, -10.0), (15.0, -19.0, -10.0))
    assert right_angle == pytest.approx(math.sqrt(3.0 * 0.5 * 2.0), abs=0.01)
    assert corner_speed(p, (0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (20.0, 0.0, 0.0)) == p['MPC_XY_CRUISE']
    assert corner_speed(p, (0.0, 0.0, 0.0), (10.0, 0.0, 0.0), None) == 0.0


def test_takeoff_completes_nav_mc_alt_rad_short_and_loiters_at_the_takeoff_altitude():
    f = make()
    f.request_arming(True, False, 0.0)
    f.takeoff(NAN, 500.0, 0.0)
    t = 0.0
    while f.commander.nav_mode == 'AUTO.TAKEOFF' and t < 20.0:
        t = fly(f, t, 0.01)
    height = f.vehicle.height()
    assert 2.5 - f.params['NAV_MC_ALT_RAD'] - 0.05 <= height <= 2.5 - f.params['NAV_MC_ALT_RAD'] + 0.1
    fly(f, t, 8.0)
    assert f.vehicle.height() == pytest.approx(2.5, abs=0.15), 'AUTO.LOITER holds the takeoff altitude'


def test_takeoff_leaves_the_ground_after_spool_up_and_ramp():
    """COM_SPOOLUP_TIME 1 s, then MPC_TKO_RAMP_T from zero thrust: off the ground about 2-3 s after arming."""
    f = make()
    f.on_offboard_setpoint(position_setpoint(), 0.0)
    f.request_mode('OFFBOARD', 0.0)
    f.request_arming(True, False, 0.0)
    t = 0.0
    while f.vehicle.ground_contact and t < 10.0:
        t = fly(f, t, 0.01, position_setpoint())
    assert 2.0 <= t <= 3.5


def test_drag_holds_a_long_leg_near_ten_metres_a_second():
    """SIH's linear drag against the 45 deg tilt limit: below MPC_XY_VEL_MAX 12, as PX4's 10.1 m/s (its
    estimate's, LOCAL_POSITION_NED: so is this one), within the flight fit's tolerance of PX4's runs."""
    figures = load('px4-sitl-flight-figures.json')
    px4, tolerance = figures['figures']['offboard']['leg_peak_speed_mps'], figures['tolerance']
    f = make()
    f.on_offboard_setpoint(position_setpoint(d=-20.0), 0.0)
    f.request_mode('OFFBOARD', 0.0)
    f.request_arming(True, False, 0.0)
    t = fly(f, 0.0, 20.0, position_setpoint(d=-20.0))
    peak = 0.0
    for _ in range(150):
        t = fly(f, t, 0.1, position_setpoint(n=300.0, d=-20.0))
        peak = max(peak, math.hypot(*f.vehicle.estimate[1][:2]))
    assert min(px4) * (1 - tolerance) <= peak <= min(11.0, max(px4) * (1 + tolerance)), (peak, px4)


def test_disarm_is_refused_once_the_land_detector_no_longer_says_maybe_landed():
    """reference/px4-sitl-measured.md, "Turn 3 recordings", section 6: OFFBOARD with setpoint z = -2, a disarm
    0.93 s after the arm is accepted; while the takeoff climbs it is TEMPORARILY_REJECTED and the vehicle stays
    armed and climbs; with setpoint z = 0 (it stays on the ground) a disarm 2.2 s after the arm is accepted.
    PX4's rule (Commander::disarm): refused unless landed or maybe landed, or forced."""
    for disarm_after_s, down, accepted in ((0.93, -2.0, True), (2.2, 0.0, True)):
        f = make()
        f.on_offboard_setpoint(position_setpoint(d=down), 0.0)
        f.request_mode('OFFBOARD', 0.0)
        assert f.request_arming(True, False, 0.0) == ACCEPTED
        t = fly(f, 0.0, disarm_after_s, position_setpoint(d=down))
        assert f.request_arming(False, False, t) == ACCEPTED and not f.commander.armed, (disarm_after_s, down)
    f = make()
    f.on_offboard_setpoint(position_setpoint(), 0.0)
    f.request_mode('OFFBOARD', 0.0)
    f.request_arming(True, False, 0.0)
    t = 0.0
    while f.vehicle.maybe_landed:
        t = fly(f, t, 0.01, position_setpoint())
        assert t < 3.0, 'the takeoff never lifted the land detector'
    print('maybe landed until %.2f s after the arm (PX4: before 1.9 s)' % t)
    assert f.request_arming(False, False, t) == TEMPORARILY_REJECTED and f.commander.armed
    z = f.vehicle.position[2]
    t = fly(f, t, 3.0, position_setpoint())
    assert f.commander.armed and f.vehicle.position[2] < z - 0.5, 'it stayed armed and climbed'
