"""MANUAL_CONTROL flown by the simulated PX4 as PX4 flies it (sim.manual_control): the ground station's profile that
real PX4 SITL SIH flew (reference/px4-sitl-manual-control.json: its source says how it was recorded) flown offline
on the flight stack, an ideal vehicle, the sticks at the client's 20 Hz; each phase held to what PX4 did, its
trajectory setpoints and the SIH truth from the runs' ULogs, what a ground station saw on LOCAL_POSITION_NED and
ATTITUDE. The arming refusals with PX4's texts and results; without MANUAL_CONTROL nothing changes."""

import math
from collections import namedtuple

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import manual_control as mc
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.reference import load, px4_param

M = mavlink
ORIGIN = GeoOrigin(47.397742, 8.545594, 488.0)
DT = 0.01
REFERENCE = load('px4-sitl-manual-control.json')
MAVLINK_SEEN, ULOG = REFERENCE['mavlink'], REFERENCE['ulog']
SOURCE = REFERENCE['source_figures']
MANUAL_CONTROL_PERIOD_S = REFERENCE['client']['manual_control_period_s']
NAN = float('nan')
# one step of the flight: its end time, the status, the setpoint flown (None: not flying), the takeoff state, and the
# truth (local NED position and velocity, yaw rate and yaw) of the ideal vehicle
Row = namedtuple('Row', 't status setpoint takeoff_state position velocity yaw_rate yaw')


def within(value, recorded, rel, what):
    """`value` inside the recorded runs' range widened by `rel` of its largest magnitude."""
    low, high = min(recorded), max(recorded)
    margin = rel * max(abs(low), abs(high))
    assert low - margin <= value <= high + margin, '%s: %.3f, PX4 SITL %s (+-%d %%)' % (
        what, value, recorded, round(rel * 100))


class ManualFlight:
    """A Flight on its own clock with a ground station's MANUAL_CONTROL every MANUAL_CONTROL_PERIOD_S (the sticks as
    MANUAL_CONTROL's x, y, z, r); every step's status, setpoint, takeoff state and truth recorded."""

    def __init__(self, sticks=(0, 0, 500, 0), rc=False, **params):
        self.flight = Flight(ParamStore(params), ORIGIN, 0.0, ready_delay_s=0.0, rc=rc, ideal=True)
        self.t = 0.0
        self.sticks = sticks
        self.next_s = 0.0
        self.rows = []
        self.texts = []
        self.phases = {}

    def step(self):
        if self.sticks is not None and self.t >= self.next_s - 1e-9:
            self.flight.on_manual_control(self.t, mc.from_mavlink(*self.sticks))
            self.next_s = self.t + MANUAL_CONTROL_PERIOD_S
        self.t += DT
        self.flight.step(self.t, DT)
        v = self.flight.vehicle
        self.rows.append(Row(self.t, self.flight.status(self.t), v.setpoint, v.takeoff_state, tuple(v.position),
                             tuple(v.velocity), v.yaw_rate, v.yaw))
        self.texts += [(self.t, e.text) for e in self.flight.take_events() if isinstance(e, ev.StatusText)]

    def run(self, seconds, sticks=None, phase=None):
        if sticks is not None:
            self.sticks = sticks
        start = self.t
        for _ in range(int(round(seconds / DT))):
            self.step()
        if phase:
            self.phases[phase] = (start, self.t)

    def between(self, a, b):
        """The rows of the steps after a up to b (a row is stamped with the time its step ended)."""
        return [r for r in self.rows if a < r.t <= b + 1e-9]

    def at(self, t):
        return min(self.rows, key=lambda r: abs(r.t - t))

    def moved(self, a, b):
        """(north, east) the truth moved from time a to b, m."""
        pa, pb = self.at(a).position, self.at(b).position
        return pb[0] - pa[0], pb[1] - pa[1]

    def request_mode(self, mode):
        return self.flight.request_mode(mode, self.t)

    def arm(self, force=False):
        return self.flight.request_arming(True, force, self.t)


def tilt_deg(status):
    w, x, y, z = status.attitude
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))


def speed(row):
    return math.hypot(row.velocity[0], row.velocity[1])


def trajectory_speed(row):
    return math.hypot(row.setpoint.velocity[0], row.setpoint.velocity[1])


@pytest.fixture(scope='module')
def profile():
    """The ground station's profile (reference: 'profile'), from arming in POSCTL with centred sticks on."""
    f = ManualFlight()
    f.run(1.0)
    assert f.request_mode('POSCTL') == M.MAV_RESULT_ACCEPTED
    assert f.arm() == M.MAV_RESULT_ACCEPTED
    for name, (x, y, z, r), seconds, mode in REFERENCE['profile']['flight']:
        if mode != f.flight.commander.nav_mode:
            assert f.request_mode(mode) == M.MAV_RESULT_ACCEPTED, mode
        f.run(seconds, (x, y, z, r), name)
    return f


# -- MANUAL_CONTROL as PX4 reads it ----------------------------------------------------------------------------

def test_manual_control_fields_as_px4s_receiver_scales_them():
    s = SOURCE['mavlink_receiver']
    axis, z_low, z_high = s['xyr_full_scale'], s['z_range'][0], s['z_range'][1]
    centre = (z_low + z_high) // 2
    sticks = mc.from_mavlink(axis, -axis, z_high, axis // 2)
    assert (sticks.pitch, sticks.roll, sticks.throttle, sticks.yaw) == (1.0, -1.0, 1.0, 0.5)
    assert mc.from_mavlink(0, 0, centre, 0).throttle == 0.0
    assert mc.from_mavlink(0, 0, z_low, 0).throttle == -1.0
    out_of_range = mc.from_mavlink(axis + 1, -axis - 1, z_high + 1, 32767)
    assert out_of_range == mc.ManualControlSetpoint(), 'a field out of its range is left at 0, as PX4 leaves it'


def z_for(throttle):
    """MANUAL_CONTROL's z for a throttle stick of -1..1 (the inverse of the receiver's scaling)."""
    z_low, z_high = SOURCE['mavlink_receiver']['z_range']
    return int(round(z_low + (throttle + 1.0) * (z_high - z_low) / 2.0))


@pytest.mark.parametrize('above', [False, True])
def test_takeoff_only_above_px4s_takeoff_throttle(above):
    """FlightTaskManualAltitude::_checkTakeoff: a throttle above the centre but not above the takeoff threshold
    asks for a climb without a takeoff."""
    threshold = SOURCE['flight_task_manual_altitude']['takeoff_throttle']
    f = ManualFlight()
    f.run(1.0)
    assert f.request_mode('POSCTL') == M.MAV_RESULT_ACCEPTED
    assert f.arm() == M.MAV_RESULT_ACCEPTED
    f.run(2.0)
    f.run(3.0, (0, 0, z_for(threshold + (0.05 if above else -0.05)), 0))
    assert (f.flight.vehicle.takeoff_state in ('rampup', 'flight')) == above, f.flight.vehicle.takeoff_state


@pytest.mark.parametrize('mode, throttle_key, offset, refused', [
    ('POSCTL', 'throttle_above_center', 0.04, True), ('POSCTL', 'throttle_above_center', -0.04, False),
    ('STABILIZED', 'throttle_low', 0.04, True), ('STABILIZED', 'throttle_low', -0.04, False)])
def test_arming_throttle_thresholds_as_px4s_commander(mode, throttle_key, offset, refused):
    throttle = SOURCE['commander'][throttle_key] + offset
    f = ManualFlight(sticks=(0, 0, z_for(throttle), 0))
    f.run(1.0)
    assert f.request_mode(mode) == M.MAV_RESULT_ACCEPTED
    result = f.arm()
    assert (result == M.MAV_RESULT_TEMPORARILY_REJECTED) == refused, (mode, throttle, result, f.texts[-1:])


# -- POSCTL -----------------------------------------------------------------------------------------------------

def test_centred_sticks_after_arming_stay_on_the_ground(profile):
    start, end = profile.phases['armed']
    heights = [-r.position[2] for r in profile.between(start, end)]
    assert max(heights) <= max(ULOG['takeoff']['truth_height_before_climb_m']) + 0.01, max(heights)
    assert all(r.takeoff_state in ('spoolup', 'ready') for r in profile.between(start, end))


def test_throttle_up_takes_off_and_climbs_at_px4s_rate(profile):
    """PX4's takeoff ramp from the throttle above its takeoff threshold; the truth's liftoff spreads over PX4's
    runs by more than half a second (the estimator's vertical velocity on the ground)."""
    start, end = profile.phases['climb']
    rows = profile.between(start, end)
    ramp = next(r.t for r in rows if r.status.velocity_setpoint[2] < 2.3) - start
    tko = ULOG['takeoff']
    assert ramp <= max(tko['ramp_below_2.3_m_s_after_stick_s']), 'the takeoff ramp after %.2f s' % ramp
    within(next(r.t for r in rows if r.position[2] < -0.05) - start, tko['truth_liftoff_0.05m_s'], 0.25,
           'off the ground')
    within(next(r.t for r in rows if r.position[2] < -0.3) - start, tko['truth_liftoff_0.3m_s'], 0.25, '0.3 m up')
    late = profile.between(start + 4.0, end)
    within(-sum(r.velocity[2] for r in late) / len(late), tko['truth_climb_rate_4_to_7s_m_s'], 0.1, 'climb rate')
    steady = profile.between(start + 3.0, end)
    within(sum(r.setpoint.velocity[2] for r in steady) / len(steady), tko['trajectory_vz_setpoint_m_s'], 0.01,
           'the climb asked for')
    within(-profile.at(end).position[2], tko['truth_height_end_m'], 0.15, 'height after the climb')


def test_centred_throttle_holds_the_altitude(profile):
    start, end = profile.phases['hold_alt']
    release_z = profile.at(start).position[2]
    zs = [r.position[2] for r in profile.between(start, end)]
    hold = ULOG['hold_after_climb']
    within(release_z - min(zs), hold['truth_overshoot_m'], 0.15, 'the climb carried on after the release')
    drift = abs(profile.at(end).position[2] - profile.at(end - 3.0).position[2])
    assert drift <= max(hold['truth_drift_last_3s_m']), 'altitude held: %.2f m in 3 s, PX4 %s' % (
        drift, hold['truth_drift_last_3s_m'])
    locked = [r.setpoint.position[2] == r.setpoint.position[2] for r in profile.between(end - 3.0, end)]
    assert all(locked), 'altitude locked'


def test_full_throttle_climbs_at_px4s_limits_near_the_ground(profile):
    """Full throttle from about 4 m: MPC_TKO_SPEED below MPC_LAND_ALT2, blending to MPC_Z_VEL_MAX_UP above."""
    start, end = profile.phases['climb_full']
    full = ULOG['climb_1000']
    within(-profile.at(start).position[2], full['truth_height_at_start_m'], 0.15, 'height at the start')
    within(profile.at(start + 2.9).setpoint.velocity[2], full['trajectory_vz_setpoint_end_m_s'], 0.1,
           'the climb asked for at the end')
    within(-profile.at(start + 2.9).position[2], full['truth_height_end_m'], 0.1, 'height at the end')


def test_pitch_stick_flies_forward_at_px4s_speed_and_tilt(profile):
    start, end = profile.phases['pitch']
    pitch, seen = ULOG['pitch_1000'], MAVLINK_SEEN['pitch_1000']
    for after in (1, 2):
        within(trajectory_speed(profile.at(start + after)), pitch['trajectory_speed_%ds_m_s' % after], 0.1,
               'speed asked for at %d s' % after)
    within(trajectory_speed(profile.at(end - DT)), pitch['trajectory_speed_at_release_m_s'], 0.1,
           'speed asked for at the release')
    acc = max(math.hypot(*r.setpoint.acceleration[:2]) for r in profile.between(start, end))
    within(acc, pitch['trajectory_acc_max_m_s2'], 0.1, 'acceleration asked for')
    within(speed(profile.at(end)), pitch['truth_speed_at_release_m_s'], 0.1, 'speed at the release')
    within(max(tilt_deg(r.status) for r in profile.between(start, end)), seen['tilt_max_deg'], 0.1, 'tilt')
    heading = profile.at(start).yaw
    north, east = profile.moved(start, end)
    within(north * math.cos(heading) + east * math.sin(heading), seen['distance_m'], 0.15, 'forward')


def test_released_sticks_brake_to_a_position_hold(profile):
    start, end = profile.phases['brake']
    rows = profile.between(start, end)
    lock = next(r.t for r in rows if r.setpoint.position[0] == r.setpoint.position[0]) - start
    within(lock, ULOG['pitch_1000']['position_lock_after_release_s'], 0.1, 'position locked after')
    brake = MAVLINK_SEEN['brake_after_pitch']
    stop = next(r.t for r in rows if speed(r) < 0.5) - start
    within(stop, brake['stop_0.5_m_s_s'], 0.25, 'below 0.5 m/s after')
    within(math.hypot(*profile.moved(start, end)), brake['distance_after_release_m'], 0.15, 'braking distance')
    held = math.hypot(*profile.moved(end - 2.0, end))
    assert held <= max(brake['drift_last_2s_m']), 'held: %.2f m in 2 s, PX4 %s' % (held, brake['drift_last_2s_m'])


def test_roll_stick_flies_sideways_and_brakes(profile):
    start, end = profile.phases['roll']
    within(speed(profile.at(end)), MAVLINK_SEEN['roll_1000']['speed_end_m_s'], 0.15, 'speed at the release')
    heading = profile.at(start).yaw
    north, east = profile.moved(start, end)
    assert -north * math.sin(heading) + east * math.cos(heading) > 0.9 * math.hypot(north, east), 'to the right'
    start, end = profile.phases['brake_roll']
    brake = MAVLINK_SEEN['brake_after_roll']
    within(math.hypot(*profile.moved(start, end)), brake['distance_after_release_m'], 0.15, 'braking distance')
    stop = next(r.t for r in profile.between(start, end) if speed(r) < 0.5) - start
    within(stop, brake['stop_0.5_m_s_s'], 0.25, 'below 0.5 m/s after')


def test_yaw_stick_turns_at_px4s_rate_then_holds_the_heading(profile):
    start, end = profile.phases['yaw']
    rate = max(r.yaw_rate for r in profile.between(start, end))
    within(math.degrees(rate), ULOG['yaw_1000']['yaw_rate_setpoint_max_deg_s'], 0.01, 'yaw rate asked for')
    assert math.degrees(rate) <= px4_param('MPC_MAN_Y_MAX') + 1e-6
    hold_start, hold_end = profile.phases['hold_yaw']
    locked = [r for r in profile.between(hold_start, hold_end) if r.setpoint.yaw == r.setpoint.yaw]
    assert locked, 'the heading is locked once the yaw rate has decayed'
    yaws = [r.yaw for r in profile.between(locked[0].t, hold_end)]
    assert max(yaws) - min(yaws) < math.radians(1.0), 'and held'


# -- ALTCTL and STABILIZED ------------------------------------------------------------------------------------

def test_altctl_pitch_stick_tilts_as_px4(profile):
    start, end = profile.phases['altctl_pitch']
    rows = profile.between(end - 1.0, end)
    seen = MAVLINK_SEEN['altctl_pitch_500']
    within(sum(tilt_deg(r.status) for r in rows) / len(rows), seen['tilt_deg'], 0.03, 'tilt')
    asked = profile.at(start + 1.0).setpoint
    within(math.hypot(*asked.acceleration[:2]), ULOG['altctl_pitch_500']['trajectory_acc_m_s2'], 0.01,
           'acceleration asked for')
    assert asked.velocity[0] != asked.velocity[0], 'no velocity control'
    within(speed(profile.at(end)), seen['speed_end_m_s'], 0.15, 'speed after 2 s')
    assert abs(profile.at(end).position[2] - profile.at(start).position[2]) <= 0.15, 'altitude held'


def test_stabilized_sticks_tilt_and_the_centred_throttle_hovers(profile):
    start, end = profile.phases['stab_centre']
    rows = profile.between(start + 1.0, end)
    vz = sum(r.velocity[2] for r in rows) / len(rows)
    assert abs(vz) <= max(abs(v) for v in MAVLINK_SEEN['stabilized']['vz_centred_mean_m_s']) + 0.05, vz
    start, end = profile.phases['stab_pitch']
    rows = profile.between(end - 0.4, end)
    within(sum(tilt_deg(r.status) for r in rows) / len(rows), MAVLINK_SEEN['stabilized']['tilt_pitch_500_deg'], 0.03,
           'tilt')
    within(speed(profile.at(end)), MAVLINK_SEEN['stabilized']['speed_after_1s_m_s'], 0.2, 'speed after 1 s')


def test_throttle_down_lands_and_disarms(profile):
    start, end = profile.phases['descend']
    rows = profile.between(start, end)
    descend = MAVLINK_SEEN['descend_0']
    within(max(r.velocity[2] for r in rows), descend['descent_rate_max_m_s'], 0.1, 'descent rate')
    landed = next(t for t, text in profile.texts if t >= start and text.startswith('Landing detected')) - start
    disarmed = next(t for t, text in profile.texts if t >= start and text.startswith('Disarmed by landing')) - start
    within(landed, descend['landing_detected_s'], 0.25, 'landing detected after')
    within(disarmed - landed, [b - a for a, b in zip(descend['landing_detected_s'], descend['disarmed_by_landing_s'])],
           0.1, 'disarmed after the landing')


# -- arming in a manual mode ------------------------------------------------------------------------------------

@pytest.mark.parametrize('case, mode, z, force', [
    ('posctl_throttle_800', 'POSCTL', 800, False), ('posctl_throttle_800_forced', 'POSCTL', 800, True),
    ('stabilized_throttle_500', 'STABILIZED', 500, False), ('stabilized_throttle_0', 'STABILIZED', 0, False),
    ('posctl_throttle_500', 'POSCTL', 500, False)])
def test_arming_in_a_manual_mode_as_px4_answers(case, mode, z, force):
    recorded = REFERENCE['arming'][case]
    f = ManualFlight(sticks=(0, 0, z, 0))
    f.run(1.0)
    assert f.request_mode(mode) == M.MAV_RESULT_ACCEPTED
    f.run(0.2)
    since = f.t
    assert f.arm(force) == recorded['result'], case
    f.run(0.1)
    said = [text.rstrip('\t') for t, text in f.texts if t >= since and text.startswith(('Arming', 'Armed'))]
    assert said[:1] == [recorded['text']], (case, said)


def test_the_throttle_is_not_looked_at_without_manual_control():
    """The simulated RC receiver (--rc) has no sticks: arming in STABILIZED as before."""
    f = ManualFlight(sticks=None, rc=True)
    f.run(1.0)
    assert f.request_mode('STABILIZED') == M.MAV_RESULT_ACCEPTED
    assert f.arm() == M.MAV_RESULT_ACCEPTED


# -- without MANUAL_CONTROL -----------------------------------------------------------------------------------

@pytest.mark.parametrize('mode', ['POSCTL', 'ALTCTL', 'STABILIZED'])
@pytest.mark.parametrize('presence', [False, True])
def test_no_manual_control_flies_the_navigators_setpoint(mode, presence):
    """With the simulated RC (no sticks), or MANUAL_CONTROL known only as a presence signal, a manual mode flies
    what it flew before: the navigator's hold where the mode began."""
    f = ManualFlight(sticks=None, rc=True)
    f.run(1.0)
    assert f.arm() == M.MAV_RESULT_ACCEPTED
    assert f.flight.takeoff(NAN, ORIGIN.alt0, f.t) == M.MAV_RESULT_ACCEPTED
    while f.flight.status(f.t).nav_mode != 'AUTO.LOITER':
        f.step()
        assert f.t < 30.0, 'no takeoff: %s' % (f.flight.status(f.t),)
    f.run(2.0)
    assert f.request_mode(mode) == M.MAV_RESULT_ACCEPTED
    for _ in range(300):
        if presence:
            f.flight.on_manual_control(f.t)
        f.step()
    expected = f.flight.navigator.setpoint(mode, True, f.t)
    assert f.flight.vehicle.setpoint == expected
    assert f.flight.status(f.t).landed_state == M.MAV_LANDED_STATE_IN_AIR


def test_lost_manual_control_holds_with_the_simulated_rc():
    """Sticks once flown, then MANUAL_CONTROL lost while the simulated RC stays: PX4's Sticks read centred sticks,
    so the vehicle holds where it is, not where the mode began."""
    f = ManualFlight(rc=True)
    f.run(1.0)
    assert f.request_mode('POSCTL') == M.MAV_RESULT_ACCEPTED
    assert f.arm() == M.MAV_RESULT_ACCEPTED
    f.run(2.0)
    f.run(6.0, (0, 0, 800, 0))
    f.run(4.0, (1000, 0, 500, 0))
    f.sticks = None
    f.run(8.0)
    st = f.flight.status(f.t)
    assert st.nav_mode == 'POSCTL' and not st.failsafe
    assert math.hypot(st.position[0], st.position[1]) > 10.0, 'held after braking: %s' % (st.position,)
    assert math.hypot(st.velocity[0], st.velocity[1]) < 0.3 and st.position[2] < -2.0
