"""Small numbers and helpers shared by the vehicle model's parts (sim.vehicle, sim.position_control), and PX4's
mathlib (lib/mathlib/math/Functions.hpp, AlphaFilter, SlewRate) for the manual flight tasks (sim.manual_control)."""

import math

GRAVITY = 9.80665
NAN = float('nan')
FLT_EPSILON = 1.1920929e-07


def clamp(value, low, high):
    return low if value < low else high if value > high else value


def limit_xy(vx, vy, limit):
    """The horizontal vector (vx, vy) no longer than `limit` (zero for a limit at or below 0)."""
    norm = math.hypot(vx, vy)
    if norm > limit > 0.0:
        return vx * limit / norm, vy * limit / norm
    return (0.0, 0.0) if limit <= 0.0 else (vx, vy)


def is_set(value):
    return value == value  # not NaN


def sign(value):
    return (value > 0.0) - (value < 0.0)


def expo(value, e):
    x, ec = clamp(value, -1.0, 1.0), clamp(e, 0.0, 1.0)
    return (1.0 - ec) * x + ec * x * x * x


def deadzone(value, dz):
    x, dzc = clamp(value, -1.0, 1.0), clamp(dz, 0.0, 0.99)
    return (x - sign(x) * dzc) / (1.0 - dzc) if abs(x) > dzc else 0.0


def expo_deadzone(value, e, dz):
    return expo(deadzone(value, dz), e)


def interpolate(value, x_low, x_high, y_low, y_high):
    if value <= x_low:
        return y_low
    if value > x_high:
        return y_high
    return y_low + (y_high - y_low) * (value - x_low) / (x_high - x_low)


def sqrt_linear(value):
    return 0.0 if value < 0.0 else math.sqrt(value) if value < 1.0 else value


def wrap_pi(angle):
    return math.atan2(math.sin(angle), math.cos(angle))


def alpha_filter(state, sample, dt, time_constant):
    """PX4's AlphaFilter: one update with alpha = dt / (dt + time constant)."""
    denominator = time_constant + dt
    alpha = dt / denominator if denominator > FLT_EPSILON else 1.0
    return state + alpha * (sample - state)


def slew(state, target, rate, dt):
    """PX4's SlewRate: `state` moved towards `target` by at most rate * dt."""
    step = rate * dt
    return state + clamp(target - state, -step, step)
