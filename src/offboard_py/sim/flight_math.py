"""Small numbers and helpers shared by the vehicle model's parts (sim.vehicle, sim.position_control)."""

import math

GRAVITY = 9.80665
NAN = float('nan')


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
