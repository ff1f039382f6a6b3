"""Which numbers of a PositionTarget PX4 will use, from its type_mask (POSITION_TARGET_TYPEMASK).

A NaN or infinity in a field the mask ignores is harmless (some clients fill unused
fields with NaN); one in a used field is a bad setpoint.
"""

import math

from offboard_py.dialect import mavlink

# What mavros's setpoint_position sends: position and yaw used, the rest ignored.
POSITION_YAW = (mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE |
                mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE |
                mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE |
                mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE)

# What mavros's setpoint_position/global sends: position, yaw and yaw rate used (0x1F8; the yaw rate it sends is 0).
POSITION_YAW_YAW_RATE = (mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE |
                         mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE |
                         mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)

# What mavros's setpoint_velocity sends: velocity and yaw rate used (0x5C7).
VELOCITY_YAW_RATE = (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE |
                     mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE |
                     mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE |
                     mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE)

_FIELDS = (('position.x', mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE),
           ('position.y', mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE),
           ('position.z', mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE),
           ('velocity.x', mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE),
           ('velocity.y', mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE),
           ('velocity.z', mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE),
           ('acceleration_or_force.x', mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE),
           ('acceleration_or_force.y', mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE),
           ('acceleration_or_force.z', mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE),
           ('yaw', mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE),
           ('yaw_rate', mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE))


def bad_used_fields(type_mask, values):
    """Names of the used fields that are not finite. `values` maps field name -> number."""
    return [name for name, bit in _FIELDS if not type_mask & bit and not math.isfinite(values[name])]


def position_target_values(msg):
    """A PositionTarget's numbers by field name."""
    p, v, a = msg.position, msg.velocity, msg.acceleration_or_force
    return {'position.x': p.x, 'position.y': p.y, 'position.z': p.z, 'velocity.x': v.x, 'velocity.y': v.y,
            'velocity.z': v.z, 'acceleration_or_force.x': a.x, 'acceleration_or_force.y': a.y,
            'acceleration_or_force.z': a.z, 'yaw': msg.yaw, 'yaw_rate': msg.yaw_rate}
