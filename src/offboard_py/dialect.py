"""The project's MAVLink vocabulary: pymavlink's `development` dialect, MAVLink 2.

`development` is `common` plus the messages current PX4 sends that `common` lacks
(CURRENT_MODE and friends). Every module that names a MAVLink message, command, enum
value or bit does it through `mavlink.<NAME>` from here (`mavlink.MAV_CMD_NAV_LAND`,
`mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE`, `mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO`),
never as a number, and builds and parses frames with the same module.
"""

from pymavlink.dialects.v20 import development as mavlink  # noqa: F401  (re-exported)

# Names from MAVLink's XML that this pymavlink release does not carry, named once here.
MAV_CMD_INJECT_FAILURE = 420   # common.xml: inject a failure (PX4, with SYS_FAILURE_EN)
FAILURE_UNIT_SENSOR_GYRO = 0   # common.xml FAILURE_UNIT (param1 of MAV_CMD_INJECT_FAILURE)
FAILURE_TYPE_OK = 0            # common.xml FAILURE_TYPE (param2): no failure
FAILURE_TYPE_OFF = 1           # common.xml FAILURE_TYPE: the unit is off

# PX4's "force" magic in COMPONENT_ARM_DISARM param2: arm or disarm whatever the checks say.
# MAVLink defines the value in the command's documentation, not as an enum.
ARM_DISARM_FORCE_MAGIC = 21196
