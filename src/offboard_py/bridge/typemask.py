"""Which numbers of a PositionTarget PX4 will use, from its type_mask (POSITION_TARGET_TYPEMASK).

A NaN or infinity in a field the mask ignores is harmless (some clients fill unused
fields with NaN); one in a used field is a bad setpoint.
"""

import math

IGNORE_PX, IGNORE_PY, IGNORE_PZ = 1, 2, 4
IGNORE_VX, IGNORE_VY, IGNORE_VZ = 8, 16, 32
IGNORE_AFX, IGNORE_AFY, IGNORE_AFZ = 64, 128, 256
IGNORE_YAW, IGNORE_YAW_RATE = 1024, 2048

_FIELDS = (('position.x', IGNORE_PX), ('position.y', IGNORE_PY), ('position.z', IGNORE_PZ),
           ('velocity.x', IGNORE_VX), ('velocity.y', IGNORE_VY), ('velocity.z', IGNORE_VZ),
           ('acceleration_or_force.x', IGNORE_AFX), ('acceleration_or_force.y', IGNORE_AFY),
           ('acceleration_or_force.z', IGNORE_AFZ), ('yaw', IGNORE_YAW), ('yaw_rate', IGNORE_YAW_RATE))


def bad_used_fields(type_mask, values):
    """Names of the used fields that are not finite. `values` maps field name -> number."""
    return [name for name, bit in _FIELDS if not type_mask & bit and not math.isfinite(values[name])]


def position_target_values(msg):
    """A PositionTarget's numbers by field name."""
    p, v, a = msg.position, msg.velocity, msg.acceleration_or_force
    return {'position.x': p.x, 'position.y': p.y, 'position.z': p.z, 'velocity.x': v.x, 'velocity.y': v.y,
            'velocity.z': v.z, 'acceleration_or_force.x': a.x, 'acceleration_or_force.y': a.y,
            'acceleration_or_force.z': a.z, 'yaw': msg.yaw, 'yaw_rate': msg.yaw_rate}
