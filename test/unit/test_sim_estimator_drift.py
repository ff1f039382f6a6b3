"""The simulated PX4's estimate errs as PX4 SITL's does, offline: a user's square flown with velocity setpoints
and vz 0 drifts in height as on PX4, and its AUTO.LAND ends disarmed in PX4's time.

Held to reference/traces/px4-sitl-velocity-square-{1,2}.csv (reference/px4-sitl-measured.md, "Turn 5 recordings":
a user's node on real PX4 SITL SIH: the tutorial's pre-stream, OFFBOARD and arm, a climb to 3 m with a position
setpoint, a 5 m square with velocity + yaw setpoints, 1 m/s slowing near each corner, vz 0, then AUTO.LAND).
Rows: t, x, y, z (ENU, t 0 at the arm); '#sp' rows the node's setpoints (t, type_mask, ...), '#state' rows
(t, mode, armed) at the HEARTBEAT's 1 Hz. The same node is flown here on the Flight, on seeds 1-8 (the system ids
of instances 0-7: each its own estimator), so the drift is not one lucky seed's.
"""

import math

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim import offboard_input
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.reference import load

from offboard_flight import DT, OffboardFlight

M = mavlink
POSITION, VELOCITY = 2552, 2503  # the node's type_masks (position + yaw; velocity + yaw)
SQUARE_ENU = ((5.0, 0.0), (5.0, 5.0), (0.0, 5.0), (0.0, 0.0))
CLIMB_M = 3.0
USER_TOLERANCE_M = 0.5  # what a user's test would allow around 3 m: PX4 fails it
SEEDS = range(1, 9)


def px4_run(n):
    """(square rows (t, x, y, z), land request s, disarmed s) of PX4's run n."""
    rows, setpoints, states = [], [], []
    for line in load('traces/px4-sitl-velocity-square-%d.csv' % n).splitlines()[1:]:
        fields = line.split(',')
        if fields[0] == '#sp':
            setpoints.append((float(fields[1]), int(fields[2])))
        elif fields[0] == '#state':
            states.append((float(fields[1]), fields[2], fields[3] == 'True'))
        elif not fields[0].startswith('#'):
            rows.append(tuple(float(v) for v in fields))
    start = min(t for t, mask in setpoints if mask == VELOCITY)
    land = min(t for t, mode, _ in states if mode == 'AUTO.LAND')
    disarmed = min(t for t, _, armed in states if t > land and not armed)
    return [r for r in rows if start <= r[0] <= land], land, disarmed


PX4 = [px4_run(n) for n in (1, 2)]
FIGURES = load('px4-sitl-velocity-square.json')['figures']
TOLERANCE = load('px4-sitl-flight-figures.json')['tolerance']


def height_range(rows):
    zs = [r[3] for r in rows]
    return max(zs) - min(zs)


def mean_speed(rows, every_s=0.5):
    """The path's length over its time, from positions every_s apart (the estimate's noise left out)."""
    picked, next_s = [], rows[0][0]
    for row in rows:
        if row[0] >= next_s:
            picked.append(row)
            next_s = row[0] + every_s
    return sum(math.hypot(b[1] - a[1], b[2] - a[2]) for a, b in zip(picked, picked[1:])) / (picked[-1][0] - picked[0][0])


def setpoint(mask, position=(0.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0), yaw=0.0):
    return offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, mask, position, velocity, (0, 0, 0), yaw, 0.0, 0.0)


def fly_the_users_square(seed):
    """The recorded node on the simulated PX4: (square rows (t, x, y, z ENU), land request s, disarmed s)."""
    of = OffboardFlight(ParamStore({'MAV_SYS_ID': seed}), GeoOrigin(47.397742, 8.545594, 488.0))
    f, rows = of.flight, []

    def record():
        st = f.status(of.t)
        rows.append((of.t, st.position[1], st.position[0], -st.position[2]))

    of.setpoint = setpoint(POSITION, position=(0.0, 0.0, -CLIMB_M))
    of.run(5.0)  # the tutorial's 100 setpoints
    assert f.request_mode('OFFBOARD', of.t) == M.MAV_RESULT_ACCEPTED
    assert f.request_arming(True, False, of.t) == M.MAV_RESULT_ACCEPTED
    of.run(10.0)
    start = of.t
    for x, y in SQUARE_ENU:  # the node's rule: toward the corner at 1 m/s, slower within 1 m, facing it
        for _ in range(int(30.0 / 0.05)):
            st = f.status(of.t)
            dx, dy = x - st.position[1], y - st.position[0]
            d = math.hypot(dx, dy)
            if d < 0.3:
                break
            speed = min(1.0, d)
            of.setpoint = setpoint(VELOCITY, velocity=(speed * dy / d, speed * dx / d, 0.0),
                                   yaw=math.pi / 2 - math.atan2(dy, dx))
            for _ in range(int(round(0.05 / DT))):
                of.step()
                record()
    square = [r for r in rows if r[0] >= start]
    land_s = of.t
    assert f.request_mode('AUTO.LAND', of.t) == M.MAV_RESULT_ACCEPTED
    disarmed_s = land_s + of.until(lambda st: not st.armed, 60.0, 'disarm after AUTO.LAND')
    return square, land_s, disarmed_s


@pytest.fixture(scope='module')
def flights():
    return {seed: fly_the_users_square(seed) for seed in SEEDS}


def test_px4_drifted_in_both_recorded_runs():
    """The recording itself: the height wandered over 1 m in the square, out of a user's +-0.5 m around 3 m."""
    for rows, _, _ in PX4:
        assert height_range(rows) > 1.0
        assert max(abs(r[3] - CLIMB_M) for r in rows) > USER_TOLERANCE_M


@pytest.mark.parametrize('seed', SEEDS)
def test_the_height_drifts_under_velocity_setpoints_as_on_px4(flights, seed):
    """Half to one and a half times PX4's drift, and a user's +-0.5 m check fails here as it failed on PX4."""
    rows = flights[seed][0]
    px4 = [height_range(r) for r, _, _ in PX4]
    drift = height_range(rows)
    assert 0.5 * min(px4) <= drift <= 1.5 * max(px4), 'height range %.2f m; PX4 %s' % (drift, px4)
    worst = max(abs(r[3] - CLIMB_M) for r in rows)
    assert worst > USER_TOLERANCE_M, 'held 3 m within %.2f m, which PX4 never did' % worst


@pytest.mark.parametrize('seed', SEEDS)
def test_the_square_is_flown_at_px4s_pace_and_lands_disarmed_in_px4s_time(flights, seed):
    """The legs' horizontal speed, and AUTO.LAND's request to disarmed, within PX4's (the recorded figure and the
    two traces, whose 1 Hz state rows see each change up to 1 s late) widened by the flight fit's tolerance."""
    rows, land_s, disarmed_s = flights[seed]
    low, high = FIGURES['horizontal_speed_mps']
    assert low * (1 - TOLERANCE) <= mean_speed(rows) <= high * (1 + TOLERANCE), (mean_speed(rows), low, high)
    px4 = [FIGURES['land_request_to_disarmed_s']] + [disarmed - land for _, land, disarmed in PX4]
    assert min(px4) * (1 - TOLERANCE) <= disarmed_s - land_s <= (max(px4) + 1.0) * (1 + TOLERANCE), (
        disarmed_s - land_s, px4)
