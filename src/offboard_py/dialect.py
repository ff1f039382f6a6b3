"""The project's MAVLink vocabulary: the `px4_development` dialect, MAVLink 2.

`mavlink` here is offboard_py.dialects.px4_development, which pymavlink's own generator (mavgen,
Python3, wire protocol 2.0) made from src/offboard_py/dialects/px4_development.xml: pymavlink's
`development` dialect (`common` plus CURRENT_MODE and friends) plus what PX4's mavlink submodule
defines, PX4 uses and pymavlink 2.4.49 lacks: the messages LINK_NODE_STATUS (8),
TIME_ESTIMATE_TO_TARGET (380) and PROTOCOL_VERSION (300), MAV_CMD_INJECT_FAILURE and its
FAILURE_UNIT and FAILURE_TYPE enums. It is a module of its own: pymavlink's modules stay as they
are, so a plain pymavlink client in the same process still sees UNKNOWN_8, as it would from PX4.

The generated module is committed, not generated at build time, so that every way of running
the code (catkin devel or install space, a venv, the source tree) finds the same module without a
build step; test/unit/test_dialect.py regenerates it from the XML and fails on any difference, so
the two cannot drift apart. Change the XML, then run `python -m offboard_py.dialects.generate`.

Every module that names a MAVLink message, command, enum value or bit does it through
`mavlink.<NAME>` from here (`mavlink.MAV_CMD_NAV_LAND`, `mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE`,
`mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO`), never as a number, and builds and parses frames with the
same module.
"""

from offboard_py.dialects import px4_development as mavlink  # noqa: F401  (re-exported)

# Short names for what the simulated PX4 and its tests inject (common.xml, MAV_CMD_INJECT_FAILURE)
MAV_CMD_INJECT_FAILURE = mavlink.MAV_CMD_INJECT_FAILURE
FAILURE_UNIT_SENSOR_GYRO = mavlink.FAILURE_UNIT_SENSOR_GYRO  # param1
FAILURE_TYPE_OK = mavlink.FAILURE_TYPE_OK                    # param2: no failure
FAILURE_TYPE_OFF = mavlink.FAILURE_TYPE_OFF                  # param2: the unit is off

# PX4's "force" magic in COMPONENT_ARM_DISARM param2: arm or disarm whatever the checks say.
# MAVLink defines the value in the command's documentation, not as an enum.
ARM_DISARM_FORCE_MAGIC = 21196

