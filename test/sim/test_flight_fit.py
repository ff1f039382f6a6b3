"""The simulated multicopter flies like PX4 SITL: the recorded profiles of
reference/px4-sitl-measured.md flown offline against the simulator's flight stack
(flight_profiles: the Flight on a simulated clock, no sockets, a few seconds for all of them),
their figures held within 10 % of PX4's (reference/px4-sitl-flight-figures.json: PX4's numbers and traces,
copied from the reference files), the parameters driving the flight as on PX4, and runs that
repeat exactly for a seed.

The fit as a picture: every run writes flight-fit.png (simulator versus PX4, height and
horizontal distance over time) into pytest's tmp dir; FLIGHT_FIT_PLOT=out/flight-fit.png
writes it there too:
    FLIGHT_FIT_PLOT=out/flight-fit.png python -m pytest -q test/sim/test_flight_fit.py
"""

import json
import math
import os

import pytest

import flight_profiles as fp
from offboard_py.testing.reference import load

HERE = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(HERE, '..', '..', 'reference', 'px4-sitl-flight-figures.json')) as _f:
    REFERENCE = json.load(_f)
TOLERANCE = REFERENCE['tolerance']


def fly_all():
    return {
        'offboard': fp.offboard_profile(),
        'auto_takeoff_land': fp.auto_takeoff_land_profile(),
        'mission': fp.mission_profile(),
        'land_from_20m': fp.land_from_height_profile(20.0),
        'land_from_5m': fp.land_from_height_profile(5.0),
        'posctl_square': fp.posctl_square_profile(),
    }


@pytest.fixture(scope='module')
def flights():
    return fly_all()


def within(value, px4_runs, tolerance=TOLERANCE):
    """Within `tolerance` of PX4's figure: of the span of its runs, widened by the tolerance."""
    return value is not None and min(px4_runs) * (1.0 - tolerance) <= value <= max(px4_runs) * (1.0 + tolerance)


def fit_table(flights):
    """(profile, figure, PX4's runs, ours, within) for every compared figure."""
    rows = []
    for profile, figures in REFERENCE['figures'].items():
        ours = flights[profile][0]
        for name, px4_runs in figures.items():
            rows.append((profile, name, px4_runs, ours.get(name), within(ours.get(name), px4_runs)))
    return rows


@pytest.mark.parametrize('profile,name', [(p, n) for p, figures in REFERENCE['figures'].items() for n in figures])
def test_figure_within_ten_percent_of_px4(flights, profile, name):
    px4_runs = REFERENCE['figures'][profile][name]
    ours = flights[profile][0].get(name)
    assert within(ours, px4_runs), '%s %s: ours %s, PX4 %s (+-%d %%)' % (
        profile, name, ours, px4_runs, TOLERANCE * 100)


def test_offboard_loss_returns_and_the_return_stays_under_the_return_altitude(flights):
    figures, trace = flights['offboard']
    assert figures['mode_after_loss'] == 'AUTO.RTL'
    home_z = trace[0][7]  # on the ground before arming: where home is
    rtl = [row for row in trace if row[2] == 'AUTO.RTL']
    assert max(home_z - row[7] for row in rtl) <= 30.0 + 0.3, 'PX4 never climbs above RTL_RETURN_ALT 30 m'


def test_the_same_seed_flies_the_same_flight_and_another_seed_another():
    first, second = fp.auto_takeoff_land_profile(seed=7)[1], fp.auto_takeoff_land_profile(seed=7)[1]
    assert first == second, 'a seeded run repeats exactly'
    other = fp.auto_takeoff_land_profile(seed=8)[1]
    assert [row[5:8] for row in other] != [row[5:8] for row in first]


def test_estimator_realism_of_px4_sitls_size_and_an_ideal_vehicle():
    r = fp.Run()
    r.run(2.0)
    on_ground = [row[7] for row in r.trace]
    # NED: PX4's estimate on the ground reads above the origin (px4-sitl-measured.md, "Turn 3
    # recordings", section 7: z -0.091 to -0.552 m over eight fresh starts; start 1, which seed 1
    # takes, -0.188 to -0.178 m)
    assert all(-0.19 <= z <= -0.17 for z in on_ground), 'PX4 SITL start 1 reads local z (NED) -0.18 m on the ground'
    hover = fp.Run()
    hover.setpoint = fp.position_setpoint(0.0, 0.0, -2.0)
    hover.run(0.5)
    hover.flight.request_mode('OFFBOARD', hover.t)
    hover.flight.request_arming(True, False, hover.t)
    hover.run(20.0)
    start = len(hover.trace)
    hover.run(60.0)
    rows = hover.trace[start:]
    zs = [row[7] for row in rows]
    xy = [math.hypot(row[5], row[6]) for row in rows]
    # PX4 SITL's 80 s hovers at 2 m (reference/px4-sitl-hover.json): z within 0.24 m of the setpoint, its mean on it
    px4 = load('px4-sitl-hover.json')['hover_80s']
    wander = max(abs(z + 2.0) for z in zs)
    assert 0.5 * min(px4['max_abs_z_minus_2_m']) <= wander <= (1 + TOLERANCE) * max(px4['max_abs_z_minus_2_m']), \
        'z wanders %.3f m in hover; PX4 %s' % (wander, px4['max_abs_z_minus_2_m'])
    assert abs(sum(zs) / len(zs) + 2.0) <= 0.05, 'the hover is centred on the setpoint, as PX4\'s'
    assert 0.2 <= max(xy) <= 0.7, 'PX4: xy wanders up to 0.6 m in hover'
    ideal = fp.Run(ideal=True)
    ideal.run(2.0)
    assert all(row[5:11] == (0.0,) * 6 for row in ideal.trace), 'ideal: exact, the ground at z = 0'


def test_set_ideal_is_what_sim_px4_ideal_does():
    r = fp.Run()
    r.flight.set_ideal()
    assert r.status().home == (0.0, 0.0, 0.0)
    r.run(1.0)
    assert r.status().position == (0.0, 0.0, 0.0) and r.status().landed_state == fp.M.MAV_LANDED_STATE_ON_GROUND


def test_home_is_set_again_at_arming():
    r = fp.Run()
    r.run(1.0)
    before = r.status().home
    r.flight.request_arming(True, False, r.t)
    assert r.status().home != before and r.status().home == pytest.approx(before, abs=0.1)
    assert r.status().height == pytest.approx(0.0, abs=0.1)


def test_parameters_drive_the_flight_as_on_px4():
    base = fp.offboard_profile()[0]
    higher = fp.offboard_profile(params={'RTL_RETURN_ALT': 40.0})[0]
    assert higher['rtl_return_alt_m'] == pytest.approx(40.0, abs=0.5)
    assert higher['loss_to_landed_s'] > base['loss_to_landed_s'] + 5.0
    slower = fp.mission_profile(params={'MPC_XY_CRUISE': 3.0})[0]
    assert slower['arm_to_item_4_s'] > fp.mission_profile()[0]['arm_to_item_4_s'] + 3.0
    gentle = fp.land_from_height_profile(5.0, params={'MPC_LAND_SPEED': 0.6})[0]['land_to_landed_s']
    brisk = fp.land_from_height_profile(5.0, params={'MPC_LAND_SPEED': 1.2})[0]['land_to_landed_s']
    assert brisk < gentle - 1.0


def test_rtl_inside_the_cone_returns_lower():
    """RTL_CONE_ANG: within RTL_MIN_DIST of home PX4 climbs only to the cone (distance / tan(angle))."""
    r = fp.Run(ideal=True, params={'RTL_CONE_ANG': 45})
    f = r.flight
    r.setpoint = fp.position_setpoint(6.0, 0.0, -3.0)
    r.run(0.5)
    f.request_mode('OFFBOARD', r.t)
    f.request_arming(True, False, r.t)
    r.run(20.0)
    f.request_mode('AUTO.RTL', r.t)
    r.setpoint = None
    r.run(8.0)
    peak = max(-row[7] for row in r.trace if row[2] == 'AUTO.RTL')
    assert peak == pytest.approx(6.0, abs=0.5), 'cone at 6 m from home with 45 deg: 6 m, not RTL_RETURN_ALT'


def plot(flights, path):
    """Simulator versus PX4: height and horizontal distance over time, one row per profile."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    profiles = ('offboard', 'auto_takeoff_land', 'mission')
    fig, axes = plt.subplots(len(profiles), 2, figsize=(13, 10), squeeze=False)
    for row, profile in enumerate(profiles):
        px4 = REFERENCE['traces'][profile]
        trace = flights[profile][1]
        armed_s = next(r[0] for r in trace if r[3])
        t = [r[0] - armed_s for r in trace]
        ours = {'height': [-r[7] for r in trace], 'horizontal': [math.hypot(r[5], r[6]) for r in trace]}
        for col, key in enumerate(('height', 'horizontal')):
            ax = axes[row][col]
            ax.plot(px4['t'], px4[key], label='PX4 SITL (SIH)', color='tab:blue')
            ax.plot(t, ours[key], label='sim_px4', color='tab:orange', linestyle='--')
            ax.set_title('%s: %s' % (profile, 'height -z (m)' if key == 'height' else 'horizontal distance (m)'))
            ax.set_xlabel('s after arming')
            ax.grid(True, alpha=0.3)
            ax.legend(loc='best', fontsize=8)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def test_fit_plot_is_written(flights, tmp_path):
    pytest.importorskip('matplotlib')
    paths = [str(tmp_path / 'flight-fit.png')]
    if os.environ.get('FLIGHT_FIT_PLOT'):
        paths.append(os.environ['FLIGHT_FIT_PLOT'])
    for path in paths:
        plot(flights, path)
        assert os.path.getsize(path) > 10000


if __name__ == '__main__':
    table = fit_table(fly_all())
    for profile, name, px4_runs, ours, ok in table:
        print('%-18s %-24s PX4 %-14s ours %-8s %s' % (profile, name, '/'.join('%g' % v for v in px4_runs),
                                                     'n/a' if ours is None else '%.2f' % ours,
                                                     'yes' if ok else 'NO'))
