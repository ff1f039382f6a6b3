"""Offboard input of the simulated PX4: a SET_POSITION_TARGET_LOCAL_NED -> a vehicle Setpoint.

As PX4 reads the message (reference/px4-behaviour.md and px4-sitl-measured.md):
- frames LOCAL_NED and BODY_NED; BODY_NED rotates velocity and acceleration by the
  vehicle's yaw and ignores position; any other frame is refused;
- each axis whose POSITION_TARGET_TYPEMASK_*_IGNORE bit is set is left uncontrolled;
- the FORCE bit is taken as a normal setpoint when acceleration is ignored anyway
  (measured on PX4 SITL) and refused when it would make an acceleration a force;
- a message that controls no position, velocity or acceleration is refused, and so is
  an infinite number anywhere.
Pure: it never sees a socket or a clock. Whether OFFBOARD flies it is the commander's rule.
"""

import math

from offboard_py.dialect import mavlink
from offboard_py.sim import vehicle as vm

_AXIS_IGNORE_BITS = (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)
_ACCELERATION_IGNORED = (mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE
                         | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)
SUPPORTED_FRAMES = (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_NED)


class SetpointRejected(ValueError):
    """A SET_POSITION_TARGET_LOCAL_NED that PX4 would not take; the message says why."""


def offboard_setpoint(frame, type_mask, position, velocity, acceleration, yaw, yaw_rate, vehicle_yaw):
    """Decode the fields of a SET_POSITION_TARGET_LOCAL_NED into a vehicle Setpoint. Raises SetpointRejected."""
    if frame not in SUPPORTED_FRAMES:
        raise SetpointRejected('coordinate frame %d is not supported (MAV_FRAME_LOCAL_NED %d or MAV_FRAME_BODY_NED %d)'
                               % (frame, mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_NED))
    if type_mask & mavlink.POSITION_TARGET_TYPEMASK_FORCE_SET and \
            type_mask & _ACCELERATION_IGNORED != _ACCELERATION_IGNORED:
        raise SetpointRejected('force setpoints (POSITION_TARGET_TYPEMASK_FORCE_SET with an acceleration) '
                               'are not supported')
    values = list(position) + list(velocity) + list(acceleration) + [yaw, yaw_rate]
    if any(math.isinf(v) for v in values):
        raise SetpointRejected('infinite value in setpoint')
    nan = vm.NAN
    used = [float(v) if not type_mask & bit else nan for bit, v in zip(_AXIS_IGNORE_BITS, values)]
    if frame == mavlink.MAV_FRAME_BODY_NED:
        c, s = math.cos(vehicle_yaw), math.sin(vehicle_yaw)
        used[0:3] = [nan, nan, nan]
        for k in (3, 6):
            x, y = used[k], used[k + 1]
            if x == x and y == y:
                used[k], used[k + 1] = c * x - s * y, s * x + c * y
    if not any(v == v for v in used):
        raise SetpointRejected('no position, velocity or acceleration in setpoint (type_mask 0x%x)' % type_mask)
    yaw_sp = float(yaw) if not type_mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE and yaw == yaw else nan
    rate_sp = (float(yaw_rate) if not type_mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
               and yaw_rate == yaw_rate else nan)
    return vm.setpoint(position=used[0:3], velocity=used[3:6], acceleration=used[6:9], yaw=yaw_sp, yaw_rate=rate_sp)


def from_message(msg, vehicle_yaw):
    """offboard_setpoint() of a pymavlink SET_POSITION_TARGET_LOCAL_NED."""
    return offboard_setpoint(msg.coordinate_frame, msg.type_mask, (msg.x, msg.y, msg.z), (msg.vx, msg.vy, msg.vz),
                             (msg.afx, msg.afy, msg.afz), msg.yaw, msg.yaw_rate, vehicle_yaw)
