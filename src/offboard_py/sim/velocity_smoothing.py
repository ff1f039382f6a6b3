"""PX4's velocity smoothing for the simulated PX4's manual flight tasks (src/lib/motion_planning/VelocitySmoothing.cpp
and ManualVelocitySmoothingZ.cpp at 02e73e3b6f): a jerk-limited trajectory toward a velocity setpoint, and its
vertical use in ALTCTL and POSCTL, which locks the altitude where a smoothed climb stops. Pure: dt is passed in."""

import math

from offboard_py.sim.flight_math import FLT_EPSILON, NAN, clamp, is_set, sign

POSITION_LOCK_SPEED = 0.1   # ManualVelocitySmoothingZ::checkPositionLock: m/s ...
POSITION_LOCK_ACC = 0.2     # ... and m/s^2 under which the altitude is locked


class VelocitySmoothing:
    """PX4's VelocitySmoothing (lib/motion_planning): one axis brought to a velocity setpoint along a
    time-optimal profile of at most `max_jerk`, `max_accel`, with its position integrated."""

    def __init__(self, accel=0.0, vel=0.0, pos=0.0):
        self.max_jerk = self.max_accel = self.max_vel = 0.0
        self.reset(accel, vel, pos)

    def reset(self, accel, vel, pos):
        self.j, self.a, self.v, self.x = 0.0, accel, vel, pos
        self._start = (accel, vel, pos)
        self._local_time = 0.0
        self._durations = (0.0, 0.0, 0.0)
        self._direction = 0

    def set_current_velocity(self, vel):
        self.v = vel
        self._start = (self._start[0], vel, self._start[2])

    def set_current_position(self, pos):
        self.x = pos
        self._start = (self._start[0], self._start[1], pos)

    def update_durations(self, vel_setpoint):
        """A new velocity setpoint: the profile from the state now."""
        target = clamp(vel_setpoint, -self.max_vel, self.max_vel)
        self._local_time = 0.0
        self._start = (self.a, self.v, self.x)
        self._direction = self._compute_direction(target)
        jerk = self._direction * self.max_jerk
        if abs(jerk) <= FLT_EPSILON:
            self._durations = (0.0, 0.0, 0.0)
            return
        delta_v = target - self.v
        t1 = self._t1(self.a, delta_v, jerk)
        t3 = max(self.a / jerk + t1, 0.0)
        den = self.a + jerk * t1
        t2 = 0.0
        if abs(den) > FLT_EPSILON:
            t2 = (-0.5 * t1 * t1 * jerk - t1 * t3 * jerk - t1 * self.a + 0.5 * t3 * t3 * jerk - t3 * self.a
                  + delta_v) / den
        self._durations = (t1, max(t2, 0.0), t3)

    def _compute_direction(self, target):
        vel_zero_acc = self.v  # where the velocity ends if the acceleration is brought to zero now
        if abs(self.a) > FLT_EPSILON:
            jerk = -sign(self.a) * self.max_jerk
            t = -self.a / jerk
            vel_zero_acc = self.v + self.a * t + 0.5 * jerk * t * t
        direction = sign(target - vel_zero_acc)
        return direction if direction != 0 else sign(self.a)

    def _t1(self, a0, v3, jerk):
        delta = 2.0 * a0 * a0 + 4.0 * jerk * v3
        if delta < 0.0:
            return 0.0
        root = math.sqrt(delta)
        t1 = 0.0
        for candidate in ((-a0 + 0.5 * root) / jerk, (-a0 - 0.5 * root) / jerk):
            if candidate >= 0.0 and a0 / jerk + candidate >= 0.0:
                t1 = candidate
                break
        accel_t1 = a0 + jerk * t1  # no more than the acceleration limit
        if accel_t1 > self.max_accel:
            t1 = (self.max_accel - a0) / jerk
        elif accel_t1 < -self.max_accel:
            t1 = (-self.max_accel - a0) / jerk
        return max(t1, 0.0)

    def update_traj(self, dt):
        """The state dt further along the profile: jerk towards the setpoint, constant acceleration, jerk back
        to zero acceleration, then the setpoint's constant velocity."""
        self._local_time += dt
        remain = self._local_time
        jerk = self._direction * self.max_jerk
        t1, t2, t3 = self._durations
        state = _polynomial(jerk, *self._start, min(remain, t1))
        remain -= t1
        if remain > 0.0:
            state = _polynomial(0.0, *state[1:], min(remain, t2))
            remain -= t2
        if remain > 0.0:
            state = _polynomial(-jerk, *state[1:], min(remain, t3))
            remain -= t3
        if remain > 0.0:
            state = _polynomial(0.0, 0.0, state[2], state[3], remain)
        self.j, self.a, self.v, self.x = state


def _polynomial(jerk, a0, v0, x0, t):
    """(jerk, acceleration, velocity, position) after t s of constant jerk."""
    return (jerk, a0 + jerk * t, v0 + a0 * t + 0.5 * jerk * t * t,
            x0 + v0 * t + 0.5 * a0 * t * t + jerk * t * t * t / 6.0)


class ManualVelocitySmoothingZ:
    """PX4's ManualVelocitySmoothingZ: the throttle's velocity target smoothed, with the altitude locked
    where the smoothed climb has stopped (NaN while not locked)."""

    def __init__(self, accel, vel, pos):
        self.trajectory = VelocitySmoothing(accel, vel, pos)
        self.locked = False
        self.position_setpoint = NAN
        self.max_accel_up = self.max_accel_down = self.max_vel_up = self.max_vel_down = 0.0

    def update(self, dt, velocity_target, position_estimate, velocity_setpoint_feedback):
        t = self.trajectory
        t.update_traj(dt)
        if velocity_target < 0.0:  # up
            t.max_accel, t.max_vel = self.max_accel_up, self.max_vel_up
        else:
            t.max_accel, t.max_vel = self.max_accel_down, self.max_vel_down
        if abs(t.v) < POSITION_LOCK_SPEED and abs(t.a) < POSITION_LOCK_ACC and abs(velocity_target) <= FLT_EPSILON:
            self.locked, self.position_setpoint = True, t.x
        else:
            if self.locked:  # continue from what the velocity controller was asked for
                feedback = velocity_setpoint_feedback if is_set(velocity_setpoint_feedback) else t.v
                t.set_current_velocity(feedback)
                self.locked, self.position_setpoint = False, NAN
            t.set_current_position(position_estimate)
        t.update_durations(velocity_target)
