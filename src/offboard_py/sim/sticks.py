"""PX4's stick handling for the simulated PX4's manual flight tasks (src/lib/sticks/Sticks.hpp, lib/stick_yaw/
StickYaw.cpp and flight_mode_manager/tasks/Utility/StickAccelerationXY.cpp at 02e73e3b6f): the sticks in the heading
frame, the yaw stick as a yaw rate with the heading locked at rest, and POSCTL's horizontal stick as an
acceleration with PX4's drag, brake boost and jerk limit, the position locked once stopped. Pure: dt is passed in."""

import math

from offboard_py.sim.flight_math import (FLT_EPSILON, GRAVITY, NAN, alpha_filter, clamp, interpolate, is_set,
                                         rotate_by_yaw, sign, slew, sqrt_linear)

BRAKE_BOOST_TAU_S = 0.8     # StickAccelerationXY::calculateDrag's brake boost filter


def rotate_into_heading(x, y, yaw, yaw_setpoint):
    """Sticks::rotateIntoHeadingFrameXY: (forward, right) -> (north, east) by the locked heading, else the yaw."""
    return rotate_by_yaw(x, y, yaw_setpoint if is_set(yaw_setpoint) else yaw)


def limit_unit_length(x, y):
    """Sticks::limitStickUnitLengthXY: a square gimbal's corner no longer than a full stick."""
    length = math.hypot(x, y)
    return (x / length, y / length) if length > 1.0 else (x, y)


class StickYaw:
    """PX4's StickYaw: the yaw stick -> a filtered yaw rate; the heading locked once the rate is zero."""

    def __init__(self, params):
        self.params = params
        self.yawspeed = 0.0

    def update(self, stick_yaw, yaw, yaw_setpoint, dt):
        """(yaw rate setpoint rad/s, yaw setpoint rad or NaN)."""
        p = self.params
        scale = math.radians(p['MPC_MAN_Y_MAX'])
        self.yawspeed = alpha_filter(self.yawspeed, stick_yaw * scale, dt, p['MPC_MAN_Y_TAU'])
        if abs(self.yawspeed) > FLT_EPSILON:
            return self.yawspeed, NAN
        return self.yawspeed, yaw if not is_set(yaw_setpoint) else yaw_setpoint


def maximum_tilt_acceleration(params):
    """StickTiltXY: the horizontal acceleration of a full stick, from MPC_MAN_TILT_MAX (0.02 to 3 g)."""
    tilt = math.radians(clamp(params['MPC_MAN_TILT_MAX'], 0.0, 89.0))
    return clamp(math.tan(tilt), 0.02, 3.0) * GRAVITY


class StickAccelerationXY:
    """PX4's StickAccelerationXY: the roll/pitch sticks -> a horizontal acceleration, velocity and position
    setpoint (NED), with the drag that limits the speed and brakes."""

    def __init__(self, params, velocity=(0.0, 0.0), acceleration=(0.0, 0.0)):
        self.params = params
        self.position = [NAN, NAN]
        self.velocity = list(velocity) if all(is_set(c) for c in velocity) else [0.0, 0.0]
        self.acceleration = [0.0, 0.0]
        self.acceleration_prev = [0.0, 0.0]
        self.slewed = list(acceleration) if all(is_set(c) for c in acceleration) else [0.0, 0.0]
        self.brake_boost = 1.0
        self.velocity_constraint = params['MPC_VEL_MANUAL']  # slewed at MPC_ACC_HOR towards the limit

    def update(self, stick_x, stick_y, yaw, yaw_setpoint, position, velocity_setpoint_feedback, tilt_limit, dt):
        p = self.params
        vel_manual = p['MPC_VEL_MANUAL']
        self.velocity_constraint = slew(self.velocity_constraint, vel_manual, p['MPC_ACC_HOR'], dt)
        velocity_scale = min(vel_manual, self.velocity_constraint)
        # the acceleration scales down with the velocity; twice, because of the drag the average is half
        acceleration_scale = 2.0 * p['MPC_ACC_HOR'] * velocity_scale / vel_manual
        stick_x, stick_y = limit_unit_length(stick_x, stick_y)
        if p['MPC_VEL_MAN_SIDE'] >= 0.0:
            stick_y *= p['MPC_VEL_MAN_SIDE'] / vel_manual
        if p['MPC_VEL_MAN_BACK'] >= 0.0 and stick_x < 0.0:
            stick_x *= p['MPC_VEL_MAN_BACK'] / vel_manual
        stick = rotate_into_heading(stick_x, stick_y, yaw, yaw_setpoint)
        acc = [stick[0] * acceleration_scale, stick[1] * acceleration_scale]
        drag = self._drag(acceleration_scale / velocity_scale, dt, stick)
        vel, prev = self.velocity, self.acceleration_prev
        # the drag must not turn the velocity round (an oscillation about zero otherwise)
        if ((acc[0] ** 2 + acc[1] ** 2 < FLT_EPSILON or sign(prev[0]) != sign(acc[0]) or sign(prev[1]) != sign(acc[1]))
                and vel[0] ** 2 + vel[1] ** 2 < (drag[0] ** 2 + drag[1] ** 2) * dt * dt):
            drag = [0.0, 0.0]
            vel[0] = vel[1] = 0.0
        acc = [acc[0] - drag[0], acc[1] - drag[1]]
        self._jerk_limit(acc, dt)
        acc = list(self.slewed)
        limit = math.tan(tilt_limit) * GRAVITY  # the takeoff's tilt limit (takeoff_status)
        norm = math.hypot(acc[0], acc[1])
        if norm > limit:
            acc = [acc[0] * limit / norm, acc[1] * limit / norm]
        vel[0] += acc[0] * dt
        vel[1] += acc[1] * dt
        self._lock_position(position, velocity_setpoint_feedback)
        self.acceleration = acc
        self.acceleration_prev = list(acc)

    def _drag(self, coefficient, dt, stick):
        centred = stick[0] ** 2 + stick[1] ** 2 < FLT_EPSILON  # brake harder
        boost_target = max(2.0, math.sqrt(self.params['MPC_VEL_MANUAL'])) if centred else 1.0
        self.brake_boost = alpha_filter(self.brake_boost, boost_target, dt, BRAKE_BOOST_TAU_S)
        coefficient *= self.brake_boost
        vx, vy = self.velocity
        speed = math.hypot(vx, vy)
        boosted = sqrt_linear(speed) / speed if speed > 0.0 else 0.0
        # below 1 m/s the drag grows as the square root, blended in with the brake boost
        brake_scale = interpolate(self.brake_boost, 1.0, 2.0, 0.0, 1.0)
        mixed = [brake_scale * v * boosted + (1.0 - brake_scale) * v for v in (vx, vy)]
        return [coefficient * mixed[0], coefficient * mixed[1]]

    def _jerk_limit(self, acc, dt):
        """Each axis slewed by MPC_JERK_MAX times its share of the change, for a synchronised motion."""
        dx, dy = acc[0] - self.acceleration_prev[0], acc[1] - self.acceleration_prev[1]
        norm = math.hypot(dx, dy)
        ux, uy = (dx / norm, dy / norm) if norm > FLT_EPSILON else (0.0, 0.0)
        jerk = self.params['MPC_JERK_MAX']
        self.slewed[0] = slew(self.slewed[0], acc[0], abs(ux) * jerk, dt)
        self.slewed[1] = slew(self.slewed[1], acc[1], abs(uy) * jerk, dt)

    def _lock_position(self, position, velocity_setpoint_feedback):
        moving = self.velocity[0] ** 2 + self.velocity[1] ** 2 > FLT_EPSILON
        locked = is_set(self.position[0]) and is_set(self.position[1])
        if not moving and not locked:
            self.position = [position[0], position[1]]
        elif moving and locked:
            self.position = [NAN, NAN]
            # no jump of the velocity setpoint from the position error left behind
            if all(is_set(c) for c in velocity_setpoint_feedback):
                self.velocity = list(velocity_setpoint_feedback)


# -- the flight tasks -------------------------------------------------------------------------------
