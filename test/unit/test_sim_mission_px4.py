"""The simulated PX4's navigator flies a mission as PX4's does, held to real PX4 SITL's recordings.

A mission without a takeoff item, as ground stations and SDKs upload them (reference/
px4-sitl-mission-no-takeoff-item.json and the two traces in reference/traces/, recorded on real PX4 SITL
SIH, reference/px4-sitl-measured.md "Turn 4 recordings" item 1), is flown by the pure flight stack in
simulated time: PX4 first climbs straight up to the first item's altitude (landed_state TAKEOFF), then
flies the legs (IN_AIR), reports the landing item reached over its point and then descends (LANDING).
PX4's rules are those of src/modules/navigator/mission.cpp (handleTakeoff, handleLanding,
do_need_vertical_takeoff, calculate_takeoff_altitude) at the recorded commit 02e73e3b6f.
"""

import csv
import json
import os

import pytest

from offboard_py.dialect import mavlink as M
from offboard_py.sim import events as ev
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.mavlink.mission_manager import Item
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.reference import px4_param

REFERENCE = os.path.join(os.path.dirname(__file__), '..', '..', 'reference')
RECORDED = os.path.join(REFERENCE, 'px4-sitl-mission-no-takeoff-item.json')
TRACES = [os.path.join(REFERENCE, 'traces', 'px4-sitl-mission-no-takeoff-item-%d.csv' % run) for run in (1, 2)]
TOLERANCE = 0.15  # issue 40: each reached time and the landing within 15 % of PX4's mean
NAN = float('nan')
DT = 0.02


def recorded():
    with open(RECORDED) as f:
        return json.load(f)


def trace(path):
    """The rows of a recorded trace from the arm on, with t counted from the arm."""
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r['phase'] == 'mission']
    t0 = float(rows[0]['t'])
    return [dict(r, t=float(r['t']) - t0) for r in rows]


def compress(values):
    out = []
    for value in values:
        if not out or out[-1] != value:
            out.append(value)
    return out


def mean(values):
    return sum(values) / len(values)


def mission_items(ref, origin):
    """The recorded mission as stored items, in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT (degrees, metres)."""
    items = []
    for it in ref['mission']['items']:
        lat, lon, _ = origin.to_global(it['north_m'], it['east_m'], 0.0)
        items.append(Item(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, getattr(M, it['command']), 1, 0.0, 0.0, 0.0, NAN,
                          lat, lon, it['relative_alt_m']))
    return items


def fly_recorded_mission(seconds=110.0, **params):
    """The recorded mission flown from the ground: AUTO.MISSION, then the arm at t=0. Returns the
    reached items {seq: s}, the landed time, the (t, landed_state, position, velocity) samples, the
    texts and the flight."""
    ref = recorded()
    home = ref['home']
    origin = GeoOrigin(home['lat'], home['lon'], home['alt_m'])
    f = Flight(ParamStore(params), origin, 0.0, ready_delay_s=0.0)
    f.load_mission(mission_items(ref, origin))
    assert f.request_mode('AUTO.MISSION', 0.0) == M.MAV_RESULT_ACCEPTED
    assert f.request_arming(True, False, 0.0) == M.MAV_RESULT_ACCEPTED
    reached, samples, texts, landed_s = {}, [], [], None
    t = 0.0
    while t < seconds:
        t += DT
        f.step(t, DT)
        for e in f.take_events():
            if isinstance(e, ev.ItemReached):
                reached.setdefault(e.seq, t)
            elif isinstance(e, ev.StatusText):
                texts.append(e.text)
        state = f.landed_state()
        samples.append((t, state, tuple(f.vehicle.position), tuple(f.vehicle.velocity)))
        if landed_s is None and len(reached) == 4 and state == M.MAV_LANDED_STATE_ON_GROUND:
            landed_s = t
            break
    return reached, landed_s, samples, texts, f


@pytest.fixture(scope='module')
def flown():
    return fly_recorded_mission()


def test_the_recorded_figures_are_the_measurement_files():
    """The JSON copy of the table holds what reference/px4-sitl-measured.md says, and the traces
    agree with it (landed at the time the table gives)."""
    with open(os.path.join(REFERENCE, 'px4-sitl-measured.md')) as f:
        text = f.read()
    section = text[text.index('## Turn 4 recordings'):]
    ref = recorded()['seconds_after_the_arm']
    for figures in ref['item_reached'] + [ref['landed'], ref['disarmed']]:
        for value in figures:
            assert '%.2f' % value in section, value
    for path, landed in zip(TRACES, ref['landed']):
        rows = trace(path)
        down = next(r['t'] for r in rows if r['t'] > 10.0 and r['landed'] == str(M.MAV_LANDED_STATE_ON_GROUND))
        assert down == pytest.approx(landed, abs=1.5), path


@pytest.mark.parametrize('seq', [0, 1, 2, 3])
def test_each_item_is_reached_at_px4s_time(flown, seq):
    reached, _, _, _, _ = flown
    px4 = mean(recorded()['seconds_after_the_arm']['item_reached'][seq])
    assert seq in reached, 'item %d never reached (reached: %s)' % (seq, reached)
    assert reached[seq] == pytest.approx(px4, rel=TOLERANCE), \
        'item %d reached %.2f s after the arm; PX4 %.2f s (+-15 %%)' % (seq, reached[seq], px4)


def test_the_landing_at_px4s_time(flown):
    _, landed_s, _, _, _ = flown
    px4 = mean(recorded()['seconds_after_the_arm']['landed'])
    assert landed_s is not None, 'never landed'
    assert landed_s == pytest.approx(px4, rel=TOLERANCE), 'landed %.2f s after the arm; PX4 %.2f s' % (landed_s, px4)


def test_landed_state_sequence_as_recorded(flown):
    """ON_GROUND, TAKEOFF (the vertical climb), IN_AIR (the legs), LANDING (the descent), ON_GROUND."""
    _, _, samples, _, _ = flown
    ours = compress([state for _, state, _, _ in samples])
    for path in TRACES:
        px4 = compress([int(r['landed']) for r in trace(path)])
        assert ours == px4, 'landed_state: ours %s, PX4 (%s) %s' % (ours, os.path.basename(path), px4)


def test_the_takeoff_is_vertical(flown):
    """During TAKEOFF x and y stay over the start (PX4: within 0.39-0.40 m) and the climb reaches
    about the first item's altitude before the first leg begins."""
    _, _, samples, _, _ = flown
    px4_drift = max(max(((float(r['x']) - float(t[0]['x'])) ** 2 + (float(r['y']) - float(t[0]['y'])) ** 2) ** 0.5
                        for r in t if r['landed'] == str(M.MAV_LANDED_STATE_TAKEOFF))
                    for t in (trace(p) for p in TRACES))
    start = samples[0][2]
    climb = [(p, v) for _, s, p, v in samples if s == M.MAV_LANDED_STATE_TAKEOFF]
    assert climb, 'no TAKEOFF state'
    drift = max(((p[0] - start[0]) ** 2 + (p[1] - start[1]) ** 2) ** 0.5 for p, _ in climb)
    assert drift <= 1.25 * px4_drift, 'x/y drifted %.2f m in the climb; PX4 at most %.2f m' % (drift, px4_drift)
    px4_top = [min(float(r['z']) for r in trace(p) if r['landed'] == str(M.MAV_LANDED_STATE_TAKEOFF))
               for p in TRACES]
    our_top = min(p[2] for p, _ in climb)
    assert our_top == pytest.approx(mean(px4_top), abs=1.0), 'TAKEOFF ended at z %.1f; PX4 %s' % (our_top, px4_top)


def test_the_takeoff_is_announced(flown):
    """mission.cpp handleTakeoff: mavlink_log_info "Takeoff to %.1f meters above home"."""
    _, _, _, texts, _ = flown
    assert 'Takeoff to 15.0 meters above home' in texts, texts


def test_the_landing_item_is_reached_over_its_point(flown):
    """PX4 reports the landing item reached when over it, before the descent (the item's report comes
    while IN_AIR at the leg's altitude), then lands."""
    reached, _, samples, _, _ = flown
    at = reached[3]
    state, position = next((s, p) for t, s, p, _ in samples if t >= at)
    assert state == M.MAV_LANDED_STATE_IN_AIR or state == M.MAV_LANDED_STATE_LANDING, state
    assert position[2] < -13.0, 'the landing item was reported at z %.1f, not at the leg altitude' % position[2]


def test_a_mission_started_in_the_air_above_the_items_altitude_takes_no_takeoff():
    """do_need_vertical_takeoff: in the air and above the takeoff altitude, the first waypoint is flown
    straight (no TAKEOFF state, no text)."""
    ref = recorded()
    home = ref['home']
    origin = GeoOrigin(home['lat'], home['lon'], home['alt_m'])
    f = Flight(ParamStore({}), origin, 0.0, ready_delay_s=0.0)
    f.request_arming(True, False, 0.0)
    f.takeoff(home['alt_m'] + 20.0, home['alt_m'], 0.0)
    t = 0.0
    while t < 30.0 and f.commander.nav_mode != 'AUTO.LOITER':
        t += DT
        f.step(t, DT)
    f.take_events()
    f.load_mission(mission_items(ref, origin))
    assert f.request_mode('AUTO.MISSION', t) == M.MAV_RESULT_ACCEPTED
    states, texts = set(), []
    for _ in range(int(5.0 / DT)):
        t += DT
        f.step(t, DT)
        states.add(f.landed_state())
        texts += [e.text for e in f.take_events() if isinstance(e, ev.StatusText)]
    assert states == {M.MAV_LANDED_STATE_IN_AIR}, states
    assert not any(text.startswith('Takeoff to') for text in texts), texts


# -- the rest of what a ground station's mission reaches (PX4's rules at 02e73e3b6f, read from its source) --

HOME = (47.397742, 8.545594, 488.0)


def gcs_mission_flight(items, **params):
    """A flight with `items` ((command, north_m, east_m, relative_alt_m, param1, param2) or, for MAV_FRAME_MISSION
    items, (command, param1, param2)) loaded as a ground station uploads them, in AUTO.MISSION and armed at t=0."""
    origin = GeoOrigin(*HOME)
    f = Flight(ParamStore(params), origin, 0.0, ready_delay_s=0.0)
    stored = []
    for it in items:
        if len(it) == 3:
            command, p1, p2 = it
            stored.append(Item(M.MAV_FRAME_MISSION, command, 1, p1, p2, 0.0, 0.0, 0.0, 0.0, 0.0))
        else:
            command, north, east, alt, p1, p2 = it
            lat, lon, _ = origin.to_global(north, east, 0.0)
            stored.append(Item(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, 1, p1, p2, 0.0, NAN, lat, lon, alt))
    f.load_mission(stored)
    assert f.request_mode('AUTO.MISSION', 0.0) == M.MAV_RESULT_ACCEPTED
    assert f.request_arming(True, False, 0.0) == M.MAV_RESULT_ACCEPTED
    return f


class Recorder:
    """Steps a flight, keeping the reached items, the MISSION_CURRENT seqs and the samples."""

    def __init__(self, f):
        self.f, self.t, self.reached, self.current, self.samples = f, 0.0, {}, [], []
        self.texts = []

    def run(self, seconds=None, until=None, limit_s=200.0):
        end = self.t + (seconds if seconds is not None else limit_s)
        while self.t < end:
            self.t += DT
            self.f.step(self.t, DT)
            for e in self.f.take_events():
                if isinstance(e, ev.ItemReached):
                    self.reached.setdefault(e.seq, self.t)
                elif isinstance(e, ev.MissionCurrent):
                    self.current.append(e.seq)
                elif isinstance(e, ev.StatusText):
                    self.texts.append(e.text)
            v = self.f.vehicle
            self.samples.append((self.t, tuple(v.position), tuple(v.velocity), self.f.commander.nav_mode))
            if until is not None and until(self):
                return self
        assert until is None, 'not within %.0f s: reached %s, at %s' % (limit_s, self.reached, self.f.vehicle.position)
        return self


WP, LOITER_TIME, LAND = M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_TIME, M.MAV_CMD_NAV_LAND


def test_do_change_speed_sets_the_legs_ground_speed():
    """navigator_main.cpp, VEHICLE_CMD_DO_CHANGE_SPEED: param2 > 0 is the cruising speed of what follows
    (FlightTaskAuto flies the triplet's cruising_speed); param2 -1 restores MPC_XY_CRUISE."""
    def peak(items):
        r = Recorder(gcs_mission_flight(items)).run(until=lambda r: len(items) - 1 in r.reached)
        return max((v[0] ** 2 + v[1] ** 2) ** 0.5 for _, _, v, _ in r.samples)
    plain = peak([(WP, 60, 0, 10, 0, 0), (WP, 60, 0, 10, 0, 0)])
    slow = peak([(M.MAV_CMD_DO_CHANGE_SPEED, 1, 2.0), (WP, 60, 0, 10, 0, 0), (WP, 60, 0, 10, 0, 0)])
    reset = peak([(M.MAV_CMD_DO_CHANGE_SPEED, 1, 2.0), (M.MAV_CMD_DO_CHANGE_SPEED, 1, -1.0), (WP, 60, 0, 10, 0, 0),
                  (WP, 60, 0, 10, 0, 0)])
    cruise = ParamStore({})['MPC_XY_CRUISE']
    assert plain == pytest.approx(cruise, abs=0.6), 'MPC_XY_CRUISE without a change'
    assert slow == pytest.approx(2.0, abs=0.4), 'DO_CHANGE_SPEED 2 m/s: peak %.2f' % slow
    assert reset == pytest.approx(plain, abs=0.3), 'param2 -1 restores MPC_XY_CRUISE'


def test_nav_loiter_time_holds_at_its_point_for_param1_seconds():
    """mission_block.cpp is_mission_item_reached_or_completed: NAV_LOITER_TIME is done time_inside
    (param1) seconds after its position was reached; PX4 brakes there (Mission::setActiveMissionItems,
    brake_for_hold) and holds."""
    r = Recorder(gcs_mission_flight([(LOITER_TIME, 20, 0, 5, 6.0, 0), (WP, 20, 20, 5, 0, 0)]))
    r.run(until=lambda r: 0 in r.reached)
    arrived = next(t for t, p, _, _ in r.samples if abs(p[0] - 20) <= 2.0 and abs(p[2] + 5) <= 0.8)
    assert r.reached[0] - arrived == pytest.approx(6.0, abs=0.1)
    held = [p for t, p, _, _ in r.samples if t >= arrived + 1.5]
    assert all(abs(p[0] - 20) < 1.0 and abs(p[1]) < 1.0 for p in held), 'held over the loiter point'


def test_return_to_launch_as_the_last_item_is_px4s_return_mode():
    """SDKs append NAV_RETURN_TO_LAUNCH (in MAV_FRAME_MISSION: the upload of one in a global frame is
    refused, test_sim_mission_protocol). PX4's mission issues it as a vehicle command (navigator's
    mission_block.cpp issue_command; is_mission_item_reached_or_completed: reached at once) and the commander
    switches to AUTO.RTL ("Returning to launch", Commander.cpp VEHICLE_CMD_NAV_RETURN_TO_LAUNCH), which climbs
    to RTL_RETURN_ALT beyond RTL_MIN_DIST, flies home and lands (reference/px4-sitl-measured.md, "Turn 5": AUTO.RTL
    reported during the return, 32 m seen)."""
    out_m = 3.0 * px4_param('RTL_MIN_DIST')
    r = Recorder(gcs_mission_flight([(WP, out_m, 0, 8, 0, 0), (M.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0)]))
    r.run(until=lambda r: not r.f.commander.armed, limit_s=150.0)
    assert sorted(r.reached) == [0, 1], 'the item reached as it is issued'
    assert 'Returning to launch\t' in r.texts, r.texts
    modes = [mode for _, _, _, mode in r.samples]
    assert 'AUTO.RTL' in modes and modes.index('AUTO.RTL') > modes.index('AUTO.MISSION')
    returning = [p for _, p, _, mode in r.samples if mode == 'AUTO.RTL']
    assert max(-p[2] for p in returning) >= px4_param('RTL_RETURN_ALT') - px4_param('NAV_MC_ALT_RAD'), \
        'climbed to RTL_RETURN_ALT (%.1f m)' % max(-p[2] for p in returning)
    final = r.samples[-1][1]
    assert (final[0] ** 2 + final[1] ** 2) ** 0.5 < 2.0 and r.f.vehicle.landed


def test_pause_in_loiter_and_resume_at_the_current_item():
    """Switching to AUTO.LOITER mid-mission holds (loiter.cpp); AUTO.MISSION again continues at the current
    item (MissionBase::on_activation keeps mission.current_seq), not at the start."""
    r = Recorder(gcs_mission_flight([(WP, 20, 0, 6, 0, 0), (WP, 20, 40, 6, 0, 0), (WP, 0, 40, 6, 0, 0)]))
    r.run(until=lambda r: 0 in r.reached)
    r.run(seconds=3.0)
    assert r.f.request_mode('AUTO.LOITER', r.t) == M.MAV_RESULT_ACCEPTED
    r.run(seconds=8.0)
    paused = r.samples[-1][1]
    r.run(seconds=5.0)
    assert all(abs(p[1] - paused[1]) < 0.5 for _, p, _, _ in r.samples[-250:]), 'paused: holds'
    assert 5.0 < paused[1] < 35.0, 'stopped on the leg to item 1 (east %.1f)' % paused[1]
    assert r.f.request_mode('AUTO.MISSION', r.t) == M.MAV_RESULT_ACCEPTED
    r.current.clear()
    r.run(until=lambda r: 2 in r.reached)
    assert r.current[0] == 1, 'resumed at item 1: MISSION_CURRENT %s' % r.current
    assert r.reached[1] < r.reached[2]


def test_mission_set_current_jumps_to_the_item():
    """MISSION_SET_CURRENT -> Mission::set_current_mission_index: the active mission flies the new item
    next; the skipped one is never reported."""
    r = Recorder(gcs_mission_flight([(WP, 0, 0, 6, 0, 0), (WP, 30, 0, 6, 0, 0), (WP, 0, 30, 6, 0, 0)]))
    r.run(until=lambda r: 0 in r.reached)
    assert r.f.set_mission_current(2)
    r.run(until=lambda r: 2 in r.reached)
    assert 1 not in r.reached
    assert max(p[0] for t, p, _, _ in r.samples if t > r.reached[0]) < 3.0, 'never flew north to item 1'
    assert not r.f.set_mission_current(7), 'an item the mission does not have is refused'


def test_a_mission_uploaded_while_flying_is_flown_from_its_first_item():
    """A new upload in AUTO.MISSION (MissionBase::onMissionUpdate with the upload's current_seq 0): the new
    items from the first, in the air and above the takeoff altitude so without a takeoff."""
    r = Recorder(gcs_mission_flight([(WP, 0, 0, 6, 0, 0), (WP, 40, 0, 6, 0, 0)]))
    r.run(until=lambda r: 0 in r.reached)
    r.run(seconds=2.0)
    origin = GeoOrigin(*HOME)
    lat, lon, _ = origin.to_global(0.0, -25.0, 0.0)
    r.reached.clear()
    r.current.clear()
    r.f.load_mission([Item(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, WP, 1, 0.0, 0.0, 0.0, NAN, lat, lon, 6.0)])
    r.run(until=lambda r: 0 in r.reached)
    assert r.current[:1] == [0]
    final = r.samples[-1][1]
    assert abs(final[1] + 25.0) < 3.0 and final[0] < 15.0, 'flew to the new item (at %s)' % (final,)
    assert r.f.landed_state() == M.MAV_LANDED_STATE_IN_AIR


def test_mission_item_reached_is_said_again_with_mission_current():
    """mavlink_mission.cpp MavlinkMissionManager::send(): the reached seq at once, then with each MISSION_CURRENT
    (its 1 Hz _slow_rate_limiter) another 10 times while a mission is loaded (reference/px4-sitl-measured.md,
    "Turn 5": PX4 repeats MISSION_ITEM_REACHED about once a second)."""
    from offboard_py.sim.autopilot import SimulatedPx4
    from manual_clock import ManualClock
    clock = ManualClock(1000.0)
    ap = SimulatedPx4(bind_host='127.0.0.1', local_port=0, remote_port=9, gcs=False, ready_delay_s=0.0, clock=clock)
    sent = []
    codec = M.MAVLink(None, srcSystem=ap.system_id, srcComponent=1)

    def send_many(msgs):
        for msg in msgs:
            decoded = codec.decode(bytearray((msg if hasattr(msg, 'pack') else msg.message()).pack(codec)))
            sent.append((clock.now_s, decoded))
    ap.link.send_many = send_many
    ap.link.send = lambda msg: send_many([msg])
    try:
        origin = GeoOrigin(*HOME)
        lat, lon, _ = origin.to_global(5.0, 0.0, 0.0)
        ap.flight.load_mission([Item(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, WP, 1, 0.0, 0.0, 0.0, NAN, lat, lon, 3.0)])
        assert ap.flight.request_mode('AUTO.MISSION', ap.t()) == M.MAV_RESULT_ACCEPTED
        assert ap.flight.request_arming(True, False, ap.t()) == M.MAV_RESULT_ACCEPTED
        for _ in range(int(30.0 / 0.01)):
            clock.now_s += 0.01
            ap.step(0.01)
    finally:
        ap.close_links()
    reached = [t for t, m in sent if m.get_type() == 'MISSION_ITEM_REACHED' and m.seq == 0]
    current = [t for t, m in sent if m.get_type() == 'MISSION_CURRENT']
    assert len(reached) == 11, 'once, then 10 times more: %d' % len(reached)
    assert all(t in current for t in reached[1:]), 'said again with MISSION_CURRENT'
    gaps = [b - a for a, b in zip(reached[1:], reached[2:])]
    assert all(abs(g - 1.0) < 0.02 for g in gaps), gaps
