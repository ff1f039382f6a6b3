"""Small numbers and helpers shared by the vehicle model's parts (sim.vehicle, sim.position_control), and PX4's
mathlib (lib/mathlib/math/Functions.hpp, AlphaFilter, SlewRate) for the manual flight tasks (sim.manual_control).

The simulator's quaternions are all here, in one order: (w, x, y, z), MAVLink's and PX4's, NED world and FRD
body. frames.py's are ROS's (x, y, z, w); the two meet only through frames.wxyz_to_xyzw."""

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


def rotate_by_yaw(x, y, yaw):
    """A horizontal vector turned by `yaw` (rad) about the down axis: (forward, right) in the heading
    frame -> (north, east)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * x - s * y, s * x + c * y


def alpha_filter(state, sample, dt, time_constant):
    """PX4's AlphaFilter: one update with alpha = dt / (dt + time constant)."""
    denominator = time_constant + dt
    alpha = dt / denominator if denominator > FLT_EPSILON else 1.0
    return state + alpha * (sample - state)


def slew(state, target, rate, dt):
    """PX4's SlewRate: `state` moved towards `target` by at most rate * dt."""
    step = rate * dt
    return state + clamp(target - state, -step, step)


# -- quaternions (w, x, y, z), NED/FRD ---------------------------------------------------------------


def quaternion_product(a, b):
    """The Hamilton product a * b of two quaternions (w, x, y, z)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def to_body(q, v):
    """Rotate a NED vector into the FRD body frame of attitude q (w, x, y, z)."""
    w, x, y, z = q
    return ((1 - 2 * (y * y + z * z)) * v[0] + 2 * (x * y + w * z) * v[1] + 2 * (x * z - w * y) * v[2],
            2 * (x * y - w * z) * v[0] + (1 - 2 * (x * x + z * z)) * v[1] + 2 * (y * z + w * x) * v[2],
            2 * (x * z + w * y) * v[0] + 2 * (y * z - w * x) * v[1] + (1 - 2 * (x * x + y * y)) * v[2])


def quaternion_from_thrust(acc_ned, yaw):
    """Attitude (w, x, y, z), NED/FRD, that points the thrust to give `acc_ned` with heading yaw."""
    fx, fy, fz = acc_ned[0], acc_ned[1], acc_ned[2] - GRAVITY
    norm = math.sqrt(fx * fx + fy * fy + fz * fz) or 1.0
    zb = (-fx / norm, -fy / norm, -fz / norm)          # body z (down) opposite the thrust
    yc = (-math.sin(yaw), math.cos(yaw), 0.0)
    xb = (yc[1] * zb[2] - yc[2] * zb[1], yc[2] * zb[0] - yc[0] * zb[2], yc[0] * zb[1] - yc[1] * zb[0])
    n = math.sqrt(xb[0] * xb[0] + xb[1] * xb[1] + xb[2] * xb[2]) or 1.0
    xb = (xb[0] / n, xb[1] / n, xb[2] / n)
    yb = (zb[1] * xb[2] - zb[2] * xb[1], zb[2] * xb[0] - zb[0] * xb[2], zb[0] * xb[1] - zb[1] * xb[0])
    # rotation matrix columns xb, yb, zb -> quaternion
    m00, m11, m22 = xb[0], yb[1], zb[2]
    trace = m00 + m11 + m22
    if trace > 0.0:
        s = math.sqrt(trace + 1.0) * 2.0
        return (0.25 * s, (yb[2] - zb[1]) / s, (zb[0] - xb[2]) / s, (xb[1] - yb[0]) / s)
    if m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2.0
        return ((yb[2] - zb[1]) / s, 0.25 * s, (yb[0] + xb[1]) / s, (zb[0] + xb[2]) / s)
    if m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2.0
        return ((zb[0] - xb[2]) / s, (yb[0] + xb[1]) / s, 0.25 * s, (zb[1] + yb[2]) / s)
    s = math.sqrt(1.0 + m22 - m00 - m11) * 2.0
    return ((xb[1] - yb[0]) / s, (zb[0] + xb[2]) / s, (zb[1] + yb[2]) / s, 0.25 * s)
