"""AUTO.FOLLOW_TARGET on the simulated PX4, offline: PX4's follow-me (src/modules/flight_mode_manager/tasks/
AutoFollowTarget/FlightTaskAutoFollowTarget.cpp at 02e73e3b6f) flies toward the target of FOLLOW_TARGET and keeps
FLW_TGT_DST behind it at FLW_TGT_HT, facing it (reference/px4-sitl-measured.md, "Turn 5": PX4 moved toward the
target, where the simulated PX4 used to change mode and stay). The follow parameters are PX4 SITL's.
"""

import math

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.reference import px4_param

M = mavlink
NAN = float('nan')
DT = 0.01
HOME = (47.397742, 8.545594, 488.0)


def airborne():
    f = Flight(ParamStore({}), GeoOrigin(*HOME), 0.0, ready_delay_s=0.0)
    assert f.request_arming(True, False, 0.0) == M.MAV_RESULT_ACCEPTED
    assert f.takeoff(NAN, HOME[2], 0.0) == M.MAV_RESULT_ACCEPTED
    return f, fly(f, 0.0, 12.0)


def fly(f, t, seconds, target=None, message_period_s=1.0):
    """Step the flight; `target(t)` -> (position, velocity) NED is sent as FOLLOW_TARGET every message_period_s."""
    next_message = t
    for _ in range(int(round(seconds / DT))):
        t = round(t + DT, 6)
        if target is not None and t >= next_message - 1e-9:
            f.on_follow_target(*target(t), t)
            next_message = t + message_period_s
        f.step(t, DT)
    return t


def walking_east(t, start_s=12.0, speed=2.0):
    return (30.0, speed * (t - start_s), 0.0), (0.0, speed, 0.0)


def test_follows_the_target_behind_it_at_the_follow_height_facing_it():
    f, t = airborne()
    assert f.request_mode('AUTO.FOLLOW_TARGET', t) == M.MAV_RESULT_ACCEPTED
    t = fly(f, t, 40.0, walking_east)
    target, _ = walking_east(t)
    v = f.vehicle
    north, east = target[0] - v.position[0], target[1] - v.position[1]
    distance = math.hypot(north, east)
    assert distance == pytest.approx(px4_param('FLW_TGT_DST'), abs=1.5), 'FLW_TGT_DST from the target'
    # FLW_TGT_FA 180: behind the target's course (east), so west of it
    assert east > 0.8 * distance, 'behind the target: %.1f m north, %.1f m east of the vehicle' % (north, east)
    assert v.height() == pytest.approx(px4_param('FLW_TGT_HT'), abs=0.6)
    assert abs(math.atan2(math.sin(v.yaw - math.atan2(east, north)), math.cos(v.yaw - math.atan2(east, north)))) \
        < math.radians(15), 'faces the target'
    assert f.commander.nav_mode == 'AUTO.FOLLOW_TARGET'


def test_moves_toward_a_target_and_holds_without_one():
    f, t = airborne()
    start = tuple(f.vehicle.position)
    assert f.request_mode('AUTO.FOLLOW_TARGET', t) == M.MAV_RESULT_ACCEPTED
    t = fly(f, t, 5.0)
    # no target yet: "Stay in current position", as velocity 0 (no position held, so the hover's wander stays)
    assert math.dist(start[:2], f.vehicle.position[:2]) < 1.5 and math.hypot(*f.vehicle.velocity[:2]) < 0.5
    t = fly(f, t, 10.0, lambda t: ((40.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    assert f.vehicle.position[0] > start[0] + 4.0, 'moved toward the target 40 m north'


def test_a_target_gone_silent_is_held_where_it_was_last_seen():
    """TargetEstimator: past GPS_MESSAGE_STALE_TIMEOUT_MS (3 s) without a message the estimate stops moving."""
    f, t = airborne()
    f.request_mode('AUTO.FOLLOW_TARGET', t)
    t = fly(f, t, 30.0, walking_east)
    last, _ = walking_east(t)
    t = fly(f, t, 30.0)
    v = f.vehicle
    assert math.hypot(last[0] - v.position[0], last[1] - v.position[1]) < px4_param('FLW_TGT_DST') + 3.0
    assert math.hypot(*v.velocity[:2]) < 0.5, 'stopped with the target'
