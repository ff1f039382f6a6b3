"""The simulated PX4 from boot, offline: when it says it is ready, and that a client arming on its word is taken.

Held to the two recorded conversations from real PX4 SITL's start (reference/px4-sitl-boot-timeline.json: each
change of SYS_STATUS, ESTIMATOR_STATUS, HOME_POSITION and HEARTBEAT, with the boot time of the message that
first showed it and of the one before) and to a ground station's listener from PX4's start
(reference/px4-sitl-boot-health.json). A change is held to PX4's spread: after the earliest message before it
and by the latest message that showed it, in either capture, plus one of our messages' period.
"""

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.mavlink import messages
from offboard_py.sim.main import parser
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.reference import load, px4_rate_hz

M = mavlink
ORIGIN = GeoOrigin(47.397742, 8.545594, 488.0)
DT = 0.01
GPS_OK = M.MAV_SYS_STATUS_SENSOR_GPS
CAPTURES = load('px4-sitl-boot-timeline.json')['captures']


def px4_changes(message):
    """[(value fields, [(previous boot s, first-seen boot s) per capture])] of `message`'s changes, in order."""
    per_capture = [[c for c in capture['changes'] if c['message'] == message] for capture in CAPTURES.values()]
    assert len(set(len(changes) for changes in per_capture)) == 1, 'the captures agree on how many changes'
    out = []
    for changes in zip(*per_capture):
        values = {k: v for k, v in changes[0].items() if k not in ('message', 'boot_s', 'previous_boot_s')}
        assert all({k: c[k] for k in values} == values for c in changes), 'both captures say the same'
        out.append((values, [(c['previous_boot_s'], c['boot_s']) for c in changes]))
    return out


def booted_flight():
    return Flight(ParamStore({}), ORIGIN, 0.0, ready_delay_s=parser().parse_args([]).ready_delay)


def our_changes(message, fields, seconds=8.0):
    """[(values, boot s)] of each change of `message` in a booting simulated PX4, built every step."""
    f, b = booted_flight(), messages.TelemetryBuilder(M.MAVLink(None, srcSystem=1), ORIGIN, ParamStore({}))
    out, t = [], 0.0
    for _ in range(int(round(seconds / DT))):
        t = round(t + DT, 6)
        f.step(t, DT)
        msg = b.build(message, f.status(t), t)
        values = {name: getattr(msg, name) for name in fields}
        if not out or out[-1][0] != values:
            out.append((values, t))
    return out


@pytest.mark.parametrize('message, fields, our_name', [
    ('SYS_STATUS', {'present': 'onboard_control_sensors_present', 'enabled': 'onboard_control_sensors_enabled',
                    'health': 'onboard_control_sensors_health'}, 'SYS_STATUS'),
    ('ESTIMATOR_STATUS', {'flags': 'flags'}, 'ESTIMATOR_STATUS'),
    ('HEARTBEAT', {'system_status': 'system_status'}, 'HEARTBEAT'),
])
def test_the_words_from_boot_come_in_px4s_order_and_time(message, fields, our_name):
    """SYS_STATUS: none present (a zeroed report), then the sensors without the GPS, then the GPS with
    PREARM_CHECK; ESTIMATOR_STATUS 164, 229, 1023; HEARTBEAT UNINIT, then STANDBY: the same words, each
    within PX4's spread."""
    px4 = px4_changes(message)
    ours = our_changes(our_name, list(fields.values()))
    renamed = [({short: values[long] for short, long in fields.items()}, t) for values, t in ours]
    assert [v for v, _ in renamed] == [v for v, _ in px4], 'the words and their order, as PX4 SITL'
    period_s = 1.0 / px4_rate_hz(message)
    for (values, t), (_, windows) in zip(renamed[1:], px4[1:]):
        earliest = min(prev for prev, _ in windows)
        latest = max(seen for _, seen in windows) + period_s
        assert earliest < t <= latest, '%s %s at %.2f s of boot; PX4 between %.2f and %.2f s' % (
            message, values, t, earliest, latest)


def test_home_is_set_as_the_estimator_gets_a_position_and_again_when_it_is_ready():
    px4 = [[home['time_usec'] / 1e6 for home in capture['home_position'][:2]] for capture in CAPTURES.values()]
    f, t, homes = booted_flight(), 0.0, []
    for _ in range(int(round(6.0 / DT))):
        t = round(t + DT, 6)
        f.step(t, DT)
        home_s = f.status(t).home_set_s
        if home_s is not None and home_s not in homes:
            homes.append(home_s)
    assert len(homes) == 2, 'twice before arming, as PX4: %s' % homes
    for ours, recorded in zip(homes, zip(*px4)):
        assert min(recorded) - 0.1 <= ours <= max(recorded) + 0.1, 'home set at %.2f s; PX4 %s' % (ours, recorded)


def gps_ok(sys_status):
    """A ground-station SDK's "global position ok": the GPS present, enabled and healthy in SYS_STATUS."""
    return all(word & GPS_OK for word in (sys_status.onboard_control_sensors_present,
                                          sys_status.onboard_control_sensors_enabled,
                                          sys_status.onboard_control_sensors_health))


def test_a_client_that_arms_when_gps_and_home_say_ok_is_accepted_and_one_before_is_refused():
    """px4-sitl-boot-health.json: SDKs wait for "global position ok" and "home position ok", then arm at once;
    real PX4 took it. Before that, PX4 refuses (estimator not ready) with its one line."""
    recorded = load('px4-sitl-boot-health.json')['real_px4_s_after_first_message']
    assert recorded['first HOME_POSITION'] < recorded['SYS_STATUS GPS healthy'] < recorded[
        'first arm accepted (client armed at once)'], 'the recorded order'
    f, b = booted_flight(), messages.TelemetryBuilder(M.MAVLink(None, srcSystem=1), ORIGIN, ParamStore({}))
    t, refused = 0.0, 0
    while True:
        t = round(t + DT, 6)
        assert t < 10.0, 'GPS never said ok'
        f.step(t, DT)
        st = f.status(t)
        ok = gps_ok(b.build('SYS_STATUS', st, t)) and b.build('HOME_POSITION', st, t) is not None
        if ok:
            break
        if t in (1.0, 3.0):  # an impatient client: refused, as PX4 refuses it
            assert f.request_arming(True, False, t) == M.MAV_RESULT_TEMPORARILY_REJECTED
            texts = [e.text for e in f.take_events() if hasattr(e, 'text')]
            assert 'Arming denied: Resolve system health failures first\t' in texts, texts
            refused += 1
    assert refused == 2
    assert f.request_arming(True, False, t) == M.MAV_RESULT_ACCEPTED, 'armed at %.2f s, as GPS said ok' % t
