"""Frame conversions between ROS (ENU world, FLU body) and PX4/MAVLink (NED world, FRD body).

One place for every convention the bridge uses, as mavros (ftf) does it:
- a world vector (position, velocity) swaps x and y and negates z: ENU <-> NED;
- a body vector (rates, accelerations) negates y and z: FLU <-> FRD;
- an orientation is q_ned_frd = q_NED_ENU * q_enu_flu * q_FLU_FRD (and back);
- yaw_ned = pi/2 - yaw_enu, wrapped;
- a Pose's orientation is first made the rotation mavros takes from it (pose_rotation).
Every quaternion here is an (x, y, z, w) tuple, the order of ROS messages; MAVLink's (w, x, y, z)
is converted at the edge (wxyz_to_xyzw). The simulator's own (w, x, y, z) helpers are sim.flight_math's.
Pure functions.
"""

import math

_SQRT_HALF = math.sqrt(0.5)
# Rotation taking ENU to NED (and back: it is its own inverse up to sign): 180 deg about (1, 1, 0)/sqrt(2).
Q_ENU_NED = (_SQRT_HALF, _SQRT_HALF, 0.0, 0.0)
# Rotation taking FLU to FRD: 180 deg about x.
Q_FLU_FRD = (1.0, 0.0, 0.0, 0.0)


def wrap_pi(angle):
    """Angle in (-pi, pi]."""
    wrapped = math.fmod(angle + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi


def enu_to_ned(x, y, z):
    return y, x, -z


ned_to_enu = enu_to_ned  # the same swap both ways


def flu_to_frd(x, y, z):
    return x, -y, -z


frd_to_flu = flu_to_frd


def yaw_enu_to_ned(yaw):
    return wrap_pi(math.pi / 2.0 - yaw)


yaw_ned_to_enu = yaw_enu_to_ned


def yaw_flu_to_frd(yaw):
    """A yaw in a body frame (setpoint_raw/local's BODY_NED): mavros takes the yaw of
    q_x(pi) * q_yaw, which is -yaw, wrapped."""
    return wrap_pi(-yaw)


def quaternion_multiply(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def quaternion_from_yaw(yaw):
    """Rotation of `yaw` rad about z, as (x, y, z, w)."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def quaternion_yaw(q):
    """Yaw (rad) of a quaternion (x, y, z, w), ZYX convention (mavros's ftf::quaternion_get_yaw)."""
    x, y, z, w = q
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def euler(q):
    """(roll, pitch, yaw) in rad, ZYX convention, of a quaternion (x, y, z, w)."""
    x, y, z, w = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    return roll, pitch, quaternion_yaw(q)


# How far |q|^2 may be from 1 for q to be taken as the rotation it is: mavros's rotation of such a q
# differs from q's own by under this many radians.
UNIT_TOLERANCE = 1e-6


def pose_rotation(q):
    """The rotation mavros takes from a Pose's orientation q (x, y, z, w), as a unit quaternion.

    mavros's setpoint_position/local and setpoint_attitude/attitude read a Pose through
    tf::poseMsgToEigen into an Eigen::Affine3d and take Eigen::Quaterniond(tr.rotation()):
    Eigen builds the matrix of q without normalising it, and rotation() keeps the rotation of
    that matrix's polar decomposition (an SVD). For q = s*u, u a unit quaternion turning by
    theta about axis a, the matrix is (1 - s^2) I + s^2 R_u: a scaling in the plane normal to a
    times a rotation about a by phi = atan2(s^2 sin(theta), 1 - s^2 + s^2 cos(theta)), which in
    q's own numbers is atan2(2 w |v|, 1 - 2 |v|^2), v = (x, y, z). So a user's unnormalised
    quaternion does not turn the vehicle by its own angle, and the PX4 tutorial's all-zero one
    (no axis) is the identity. Where the matrix has no rotation at all (w = 0, |v|^2 = 1/2:
    a projection onto a) the identity is given; Eigen 3.4's SVD gave the identity there too.
    Unit quaternions (within UNIT_TOLERANCE) are returned as they are.
    """
    x, y, z, w = q
    v2 = x * x + y * y + z * z
    if abs(v2 + w * w - 1.0) <= UNIT_TOLERANCE:
        return q
    if v2 == 0.0:
        return (0.0, 0.0, 0.0, 1.0)
    v = math.sqrt(v2)
    half = 0.5 * math.atan2(2.0 * w * v, 1.0 - 2.0 * v2)  # atan2(0, 0) = 0: the identity
    k = math.sin(half) / v
    return (x * k, y * k, z * k, math.cos(half))


def orientation_enu_to_ned(q_enu_flu):
    """ROS orientation (ENU world, FLU body) -> PX4 orientation (NED world, FRD body)."""
    return quaternion_multiply(quaternion_multiply(Q_ENU_NED, q_enu_flu), Q_FLU_FRD)


orientation_ned_to_enu = orientation_enu_to_ned  # both fixed rotations are their own inverses


def world_orientation_ned_to_enu(q_ned):
    """The world frame's turn alone, q_NED_ENU * q, the body's axes left as they are: mavros's
    transform_orientation_ned_enu, which its home_position plugin applies to HOME_POSITION.q."""
    return quaternion_multiply(Q_ENU_NED, q_ned)


def quaternion_conjugate(q):
    """The conjugate of q (x, y, z, w): the inverse rotation of a unit quaternion."""
    return (-q[0], -q[1], -q[2], q[3])


def rotate(q, v):
    """Rotate vector v by quaternion q (x, y, z, w); by quaternion_conjugate(q) for the inverse."""
    qv = quaternion_multiply(quaternion_multiply(q, (v[0], v[1], v[2], 0.0)), quaternion_conjugate(q))
    return qv[0], qv[1], qv[2]


def wxyz_to_xyzw(w, x, y, z):
    return x, y, z, w


# -- geodetic (WGS-84), for positions the FCU gives in latitude/longitude -----------------------

WGS84_A = 6378137.0
WGS84_E2 = 6.69437999014e-3


def geodetic_to_ecef(lat_deg, lon_deg, alt_m):
    """WGS-84 latitude, longitude (deg) and height (m) -> ECEF (m)."""
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    n = WGS84_A / math.sqrt(1.0 - WGS84_E2 * math.sin(lat) ** 2)
    return ((n + alt_m) * math.cos(lat) * math.cos(lon),
            (n + alt_m) * math.cos(lat) * math.sin(lon),
            (n * (1.0 - WGS84_E2) + alt_m) * math.sin(lat))


def ecef_offset_to_enu(d, lat_deg, lon_deg):
    """An ECEF offset vector -> (east, north, up) in the tangent plane at lat/lon (deg)."""
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    sl, cl, sp, cp = math.sin(lon), math.cos(lon), math.sin(lat), math.cos(lat)
    return (-sl * d[0] + cl * d[1],
            -sp * cl * d[0] - sp * sl * d[1] + cp * d[2],
            cp * cl * d[0] + cp * sl * d[1] + sp * d[2])
