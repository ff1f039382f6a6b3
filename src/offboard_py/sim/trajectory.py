"""The AUTO modes' setpoint trajectory of the simulated PX4, as PX4's PositionSmoothing makes it.

A point moves towards a target along the straight line, its velocity limited by the mode's
speeds (MPC_XY_CRUISE, MPC_Z_V_AUTO_UP / _DN), its acceleration by MPC_ACC_HOR and
MPC_ACC_UP_MAX / MPC_ACC_DOWN_MAX and its jerk by MPC_JERK_AUTO. It brakes in time to pass the
target at `speed_at_target` (zero, or the corner speed of a mission waypoint: PX4's
computeMaxSpeedInWaypoint). When the vehicle falls behind by more than MPC_XY_ERR_MAX the
point's time is stretched, as PX4 does, so the vehicle is never left far behind. The
controller flies the point's position with its velocity and acceleration as feed-forward.

Pure: time steps are passed in.
"""

import math


def speed_from_distance(jerk, accel, distance, final_speed):
    """Highest speed (m/s) from which a jerk- and acceleration-limited braking reaches
    `final_speed` within `distance`, as PX4 reckons it (computeMaxSpeedFromDistance: a margin of
    4 accel^2 / jerk, which makes the last metres slow)."""
    if distance <= 0.0:
        return final_speed
    b = 4.0 * accel * accel / jerk if jerk > 0.0 else 0.0
    c = -2.0 * accel * distance - final_speed * final_speed
    return 0.5 * (-b + math.sqrt(b * b - 4.0 * c))


def corner_speed(params, previous, corner, following):
    """The speed a mission passes waypoint `corner` at, between `previous` and `following`
    (NED points): sqrt(MPC_ACC_HOR * MPC_XY_TRAJ_P * NAV_ACC_RAD * tan(alpha / 2)) with alpha the
    angle at the corner (pi when straight on), no more than MPC_XY_CRUISE; zero at the end."""
    if previous is None or following is None:
        return 0.0
    a = (corner[0] - previous[0], corner[1] - previous[1])
    b = (following[0] - corner[0], following[1] - corner[1])
    na, nb = math.hypot(*a), math.hypot(*b)
    if na < 1e-3 or nb < 1e-3:
        return 0.0
    cos_alpha = max(-1.0, min(1.0, -(a[0] * b[0] + a[1] * b[1]) / (na * nb)))
    alpha = min(math.acos(cos_alpha), math.pi - 1e-3)
    accel = params['MPC_ACC_HOR'] * params['MPC_XY_TRAJ_P']
    turn = math.sqrt(accel * params['NAV_ACC_RAD'] * math.tan(alpha / 2.0))
    return min(turn, params['MPC_XY_CRUISE'], params['MPC_XY_VEL_MAX'])


class Trajectory:
    """A jerk-limited setpoint point in local NED."""

    def __init__(self, position, velocity=(0.0, 0.0, 0.0)):
        self.reset(position, velocity)

    def reset(self, position, velocity=(0.0, 0.0, 0.0)):
        self.position = list(position)
        self.velocity = list(velocity)
        self.acceleration = [0.0, 0.0, 0.0]

    def step(self, params, target, dt, vehicle_position, xy_speed=None, up_speed=None, down_speed=None,
             speed_at_target=0.0):
        """Move the point towards `target` for dt seconds of vehicle time."""
        p = params
        xy_speed = p['MPC_XY_CRUISE'] if xy_speed is None else xy_speed
        up_speed = p['MPC_Z_V_AUTO_UP'] if up_speed is None else up_speed
        down_speed = p['MPC_Z_V_AUTO_DN'] if down_speed is None else down_speed
        jerk = p['MPC_JERK_AUTO']
        acc_xy, acc_up, acc_down = p['MPC_ACC_HOR'], p['MPC_ACC_UP_MAX'], p['MPC_ACC_DOWN_MAX']
        pos, vel = self.position, self.velocity
        # time stretch: wait for a vehicle that is behind (never when it is ahead)
        behind = (pos[0] - vehicle_position[0], pos[1] - vehicle_position[1])
        stretch = 1.0 - min(1.0, math.hypot(*behind) / max(p['MPC_XY_ERR_MAX'], 1e-3))
        if behind[0] * vel[0] + behind[1] * vel[1] < 0.0:
            stretch = 1.0
        dt *= stretch
        if dt <= 0.0:
            return
        # the velocity wanted now: along the line, within the speeds, braking in time
        d = [target[i] - pos[i] for i in range(3)]
        dist = math.sqrt(sum(c * c for c in d))
        if dist < 1e-4:
            wanted = [0.0, 0.0, 0.0]
        else:
            u = [c / dist for c in d]
            uxy = math.hypot(u[0], u[1])
            speed_max, acc_line = float('inf'), float('inf')
            if uxy > 1e-6:
                speed_max, acc_line = xy_speed / uxy, acc_xy / uxy
            if abs(u[2]) > 1e-6:
                vertical, acc_vertical = (up_speed, acc_up) if u[2] < 0.0 else (down_speed, acc_down)
                speed_max = min(speed_max, vertical / abs(u[2]))
                acc_line = min(acc_line, acc_vertical / abs(u[2]))
            speed = min(speed_max, speed_from_distance(jerk, acc_line, dist, min(speed_at_target, speed_max)))
            wanted = [c * speed for c in u]
        # acceleration towards it: jerk-limited, within the acceleration limits
        acc = self.acceleration
        dv = (wanted[0] - vel[0], wanted[1] - vel[1])
        ndv = math.hypot(*dv)
        want_acc = [0.0, 0.0, 0.0]
        if ndv > 1e-6:
            a = min(acc_xy, math.sqrt(2.0 * jerk * ndv))
            want_acc[0], want_acc[1] = dv[0] / ndv * a, dv[1] / ndv * a
        dvz = wanted[2] - vel[2]
        limit_z = acc_up if dvz < 0.0 else acc_down
        want_acc[2] = math.copysign(min(limit_z, math.sqrt(2.0 * jerk * abs(dvz))), dvz)
        step = jerk * dt
        for i in range(3):
            acc[i] += max(-step, min(step, want_acc[i] - acc[i]))
            vel[i] += acc[i] * dt
            pos[i] += vel[i] * dt
        if dist < 0.01 and speed_at_target == 0.0 and math.sqrt(sum(v * v for v in vel)) < 0.05:
            self.reset(target)
