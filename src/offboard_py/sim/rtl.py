"""PX4's return altitude and return-time estimate for the simulated PX4 (src/modules/navigator/rtl.cpp, rtl_direct.cpp
and lib/rtl's estimator at 02e73e3b6f): the altitude AUTO.RTL climbs to and what TIME_ESTIMATE_TO_TARGET says.
Pure: parameters and positions are passed in (local NED, home's altitudes relative)."""

import math


def rtl_return_height(params, distance):
    """PX4's return altitude above home from `distance` (m) away: RTL_RETURN_ALT; inside
    RTL_MIN_DIST no higher than the RTL_CONE_ANG cone; at least 2 NAV_ACC_RAD outside the
    acceptance radius, 2 x the distance inside it."""
    acceptance = params['NAV_ACC_RAD']
    height = params['RTL_RETURN_ALT']
    if distance <= acceptance:
        return 2.0 * distance
    cone = params['RTL_CONE_ANG']
    if cone > 0 and distance <= params['RTL_MIN_DIST']:
        half_angle = math.radians(min(max(cone, 1.0), 89.0))
        height = min(height, distance / math.tan(half_angle))
    return max(height, 2.0 * acceptance)


def rtl_return_down(params, position, home):
    """The altitude PX4's RTL returns at from `position`, as local z (NED): the return altitude
    for its distance from home, or where the vehicle is if higher (RTL never descends to return)."""
    distance = math.hypot(position[0] - home[0], position[1] - home[1])
    return min(home[2] - rtl_return_height(params, distance), position[2])


def rtl_time_estimate(params, position, home, landed, rtl=None):
    """PX4's estimate of the time a direct return home (RTL_TYPE 0, multicopter) takes from
    `position` (local NED), in s, or None when PX4 has none (landed: PX4's RTL starts idle; its
    estimate is then invalid). `rtl`: (phase, return altitude as local z) while AUTO.RTL flies,
    whose phase the estimate starts from; else it starts where PX4's RTL would: climbing (0 m
    when at or above the return altitude), then flying home. Climbs at MPC_Z_V_AUTO_UP, flies at
    MPC_XY_CRUISE, descends to RTL_DESCEND_ALT (or the return altitude, if lower), waits
    RTL_LAND_DELAY (a negative delay waits for good, and the landing is not counted), lands at
    MPC_Z_V_AUTO_DN (navigator's RtlDirect::calc_rtl_time_estimate with lib/rtl's estimator)."""
    if landed:
        return None
    height = home[2] - position[2]
    distance = math.hypot(position[0] - home[0], position[1] - home[1])
    phase, return_down = rtl if rtl is not None else ('climb', rtl_return_down(params, position, home))
    return_height = home[2] - return_down
    down_speed = params['MPC_Z_V_AUTO_DN']
    loiter_height = min(params['RTL_DESCEND_ALT'], return_height)
    time_s = 0.0
    if phase == 'climb':
        time_s += max(0.0, return_height - height) / params['MPC_Z_V_AUTO_UP']
        height = max(height, return_height)
    if phase in ('climb', 'return'):
        time_s += distance / params['MPC_XY_CRUISE']
    if phase != 'land':
        time_s += max(0.0, height - loiter_height) / down_speed
        height = min(height, loiter_height)
        if params['RTL_LAND_DELAY'] < 0:
            return time_s
        time_s += params['RTL_LAND_DELAY']
    return time_s + max(0.0, height) / down_speed
