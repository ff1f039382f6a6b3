"""Frame conversions between ROS (ENU world, FLU body) and PX4/MAVLink (NED world, FRD body).

One place for every convention the bridge and the simulated PX4 share, as mavros does it:
positions and vectors swap x/y and negate z; an orientation q_ned_frd is
q(ENU<-NED) * q_enu_flu * q(FLU<-FRD); yaw_ned = pi/2 - yaw_enu. Quaternions are
(x, y, z, w) tuples as in ROS messages. Pure functions, no ROS imports.
"""

import math


def wrap_pi(angle):
    """Angle in (-pi, pi]."""
    wrapped = math.fmod(angle + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi


def quaternion_from_yaw(yaw):
    """Rotation of `yaw` rad about z, as (x, y, z, w)."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))
