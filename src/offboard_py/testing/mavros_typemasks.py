"""SET_POSITION_TARGET_LOCAL_NED type_mask values the tests expect, spelled with pymavlink's names.

Written out here, not taken from the bridge, so a test compares the bridge against mavros's
values rather than against itself.
"""

from offboard_py.dialect import mavlink

IGNORE_POSITION = (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE
                   | mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE)
IGNORE_VELOCITY = (mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE
                   | mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE)
IGNORE_ACCELERATION = (mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE
                       | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)
IGNORE_YAW_AND_RATE = mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE

# what mavros sends for setpoint_position/local: position and yaw (0x9F8, 2552)
POSITION_AND_YAW = IGNORE_VELOCITY | IGNORE_ACCELERATION | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
# velocity only (3527)
VELOCITY_ONLY = IGNORE_POSITION | IGNORE_ACCELERATION | IGNORE_YAW_AND_RATE
# nothing of position, velocity or acceleration used (0x1FF)
IGNORE_ALL_VECTORS = IGNORE_POSITION | IGNORE_VELOCITY | IGNORE_ACCELERATION
