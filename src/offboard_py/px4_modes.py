"""PX4 flight modes on MAVLink: custom_mode <-> mode string, the HEARTBEAT base_mode flags, and
the modes PX4 lists in AVAILABLE_MODES (MAVLink's standard modes protocol).

PX4 packs its mode into HEARTBEAT.custom_mode as main_mode << 16 | sub_mode << 24.
The strings are mavros's (AUTO.LOITER, OFFBOARD, ...). Used by the bridge (to name
modes) and by the simulated PX4 (to encode them), so both agree by construction.
"""

from collections import namedtuple

from offboard_py.dialect import mavlink

# PX4 main modes (px4_custom_mode.h; PX4's own enums, not MAVLink's)
MAIN_MANUAL, MAIN_ALTCTL, MAIN_POSCTL, MAIN_AUTO, MAIN_ACRO, MAIN_OFFBOARD, MAIN_STABILIZED, MAIN_RATTITUDE = range(1, 9)
MAIN_TERMINATION, MAIN_ALTITUDE_CRUISE = 10, 11
# PX4 AUTO sub-modes (px4_custom_mode.h)
SUB_READY, SUB_TAKEOFF, SUB_LOITER, SUB_MISSION, SUB_RTL, SUB_LAND, SUB_RTGS, SUB_FOLLOW_TARGET, SUB_PRECLAND = range(1, 10)
SUB_VTOL_TAKEOFF, SUB_EXTERNAL1 = 10, 11  # AUTO.EXTERNAL1..8: 11..18 (modes a ROS 2 program registers)
# PX4 POSCTL sub-modes
SUB_POSCTL_ORBIT, SUB_POSCTL_SLOW = 1, 2

MODES = {
    'MANUAL': (MAIN_MANUAL, 0),
    'ALTCTL': (MAIN_ALTCTL, 0),
    'POSCTL': (MAIN_POSCTL, 0),
    'ACRO': (MAIN_ACRO, 0),
    'OFFBOARD': (MAIN_OFFBOARD, 0),
    'STABILIZED': (MAIN_STABILIZED, 0),
    'RATTITUDE': (MAIN_RATTITUDE, 0),
    'AUTO.READY': (MAIN_AUTO, SUB_READY),
    'AUTO.TAKEOFF': (MAIN_AUTO, SUB_TAKEOFF),
    'AUTO.LOITER': (MAIN_AUTO, SUB_LOITER),
    'AUTO.MISSION': (MAIN_AUTO, SUB_MISSION),
    'AUTO.RTL': (MAIN_AUTO, SUB_RTL),
    'AUTO.LAND': (MAIN_AUTO, SUB_LAND),
    'AUTO.RTGS': (MAIN_AUTO, SUB_RTGS),
    'AUTO.FOLLOW_TARGET': (MAIN_AUTO, SUB_FOLLOW_TARGET),
    'AUTO.PRECLAND': (MAIN_AUTO, SUB_PRECLAND),
}
_BY_MAIN_SUB = {v: k for k, v in MODES.items()}

# Modes a pilot flies with sticks: PX4 sets MANUAL_INPUT for them and they need RC
# (ModeUtil/mode_requirements.cpp: mode_req_manual_control).
MANUAL_MODES = frozenset(('MANUAL', 'ALTCTL', 'POSCTL', 'ACRO', 'STABILIZED', 'RATTITUDE', 'POSCTL.SLOW',
                          'ALTITUDE_CRUISE'))


def encode(mode):
    """custom_mode for a mode string: mavros's names (MODES), then the modes PX4 lists in
    AVAILABLE_MODES that mavros has no name for (POSCTL.SLOW, ALTITUDE_CRUISE, POSCTL.ORBIT,
    TERMINATION, ...); KeyError for an unknown one."""
    if mode in MODES:
        return join(*MODES[mode])
    return _CUSTOM_BY_LABEL[mode]


def join(main_mode, sub_mode):
    """custom_mode from PX4's main and sub mode numbers."""
    return (int(main_mode) << 16) | (int(sub_mode) << 24)


def split(custom_mode):
    """(main_mode, sub_mode) from a PX4 custom_mode."""
    return (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF


def decode(custom_mode):
    """Mode string for a custom_mode, or None when PX4 has no such mode."""
    main, sub = split(custom_mode)
    if main == MAIN_AUTO and sub == 0:
        sub = SUB_MISSION  # AUTO with no sub-mode means a mission, as PX4 takes it
    return _BY_MAIN_SUB.get((main, sub if main == MAIN_AUTO else 0))


def mode_string(base_mode, custom_mode):
    """The string mavros shows in State.mode for a PX4 HEARTBEAT."""
    if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
        return 'MODE(0x%2X)' % base_mode  # mavros's own format, padding included
    return decode(custom_mode) or 'CMODE(%d)' % custom_mode


def base_mode_flags(mode, armed):
    """HEARTBEAT.base_mode as PX4 sets it for a multicopter in `mode`."""
    flags = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    if armed:
        flags |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    if mode in MANUAL_MODES:
        flags |= mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if mode != 'ACRO':  # ACRO controls rates, not attitude
            flags |= mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
    elif mode.startswith('AUTO.'):
        flags |= (mavlink.MAV_MODE_FLAG_AUTO_ENABLED | mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
                  | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED)
    elif mode in ('OFFBOARD', 'POSCTL.ORBIT'):  # attitude controlled, neither stick nor navigator input
        flags |= mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
    return flags


# -- AVAILABLE_MODES and CURRENT_MODE ------------------------------------------------------------

# MAV_STANDARD_MODE as PX4's mavlink submodule numbers it on the wire (reference/px4-sitl-measured.md,
# "Turn 3 recordings", section 3). pymavlink 2.4.49's development dialect still has RETURN_HOME at 5
# and numbers SAFE_RECOVERY..TAKEOFF one higher, so its constants are not used here.
STANDARD_NON_STANDARD, STANDARD_POSITION_HOLD, STANDARD_ORBIT, STANDARD_ALTITUDE_HOLD = 0, 1, 2, 4
STANDARD_SAFE_RECOVERY, STANDARD_MISSION, STANDARD_LAND, STANDARD_TAKEOFF = 5, 6, 7, 8
ADVANCED = mavlink.MAV_MODE_PROPERTY_ADVANCED
NOT_USER_SELECTABLE = mavlink.MAV_MODE_PROPERTY_NOT_USER_SELECTABLE

AvailableMode = namedtuple('AvailableMode', 'label custom_mode standard_mode properties mode_name')
AvailableMode.__doc__ = """One AVAILABLE_MODES entry: our label for the mode, and the message's fields.
mode_name is empty exactly where standard_mode is not 0 (PX4 names only its non-standard modes)."""


def _mode(label, main_mode, sub_mode, standard_mode, properties, mode_name=''):
    return AvailableMode(label, join(main_mode, sub_mode), standard_mode, properties, mode_name)


# What PX4 SITL (sihsim_quadx) answers to MAV_CMD_REQUEST_MESSAGE(AVAILABLE_MODES), in its order:
# mode_index is the position here + 1 (reference/px4-sitl-measured.md, section 3).
AVAILABLE_MODES = (
    _mode('MANUAL', MAIN_MANUAL, 0, STANDARD_NON_STANDARD, ADVANCED, 'Manual'),
    _mode('ALTCTL', MAIN_ALTCTL, 0, STANDARD_ALTITUDE_HOLD, 0),
    _mode('POSCTL', MAIN_POSCTL, 0, STANDARD_POSITION_HOLD, 0),
    _mode('AUTO.MISSION', MAIN_AUTO, SUB_MISSION, STANDARD_MISSION, ADVANCED),
    _mode('AUTO.LOITER', MAIN_AUTO, SUB_LOITER, STANDARD_NON_STANDARD, ADVANCED, 'Hold'),
    _mode('AUTO.RTL', MAIN_AUTO, SUB_RTL, STANDARD_SAFE_RECOVERY, ADVANCED),
    _mode('POSCTL.SLOW', MAIN_POSCTL, SUB_POSCTL_SLOW, STANDARD_NON_STANDARD, ADVANCED, 'Position Slow'),
    _mode('ALTITUDE_CRUISE', MAIN_ALTITUDE_CRUISE, 0, STANDARD_NON_STANDARD, ADVANCED, 'Altitude Cruise'),
    _mode('ACRO', MAIN_ACRO, 0, STANDARD_NON_STANDARD, ADVANCED, 'Acro'),
    _mode('TERMINATION', MAIN_TERMINATION, 0, STANDARD_NON_STANDARD, ADVANCED | NOT_USER_SELECTABLE, 'Termination'),
    _mode('OFFBOARD', MAIN_OFFBOARD, 0, STANDARD_NON_STANDARD, ADVANCED, 'Offboard'),
    _mode('STABILIZED', MAIN_STABILIZED, 0, STANDARD_NON_STANDARD, ADVANCED, 'Stabilized'),
    _mode('AUTO.TAKEOFF', MAIN_AUTO, SUB_TAKEOFF, STANDARD_TAKEOFF, ADVANCED),
    _mode('AUTO.LAND', MAIN_AUTO, SUB_LAND, STANDARD_LAND, ADVANCED),
    _mode('AUTO.FOLLOW_TARGET', MAIN_AUTO, SUB_FOLLOW_TARGET, STANDARD_NON_STANDARD, ADVANCED, 'Follow Target'),
    _mode('AUTO.PRECLAND', MAIN_AUTO, SUB_PRECLAND, STANDARD_NON_STANDARD, ADVANCED, 'Precision Landing'),
    _mode('POSCTL.ORBIT', MAIN_POSCTL, SUB_POSCTL_ORBIT, STANDARD_ORBIT, ADVANCED),
    _mode('AUTO.VTOL_TAKEOFF', MAIN_AUTO, SUB_VTOL_TAKEOFF, STANDARD_NON_STANDARD, ADVANCED, 'VTOL Takeoff'),
) + tuple(
    # external modes: none registered, so not selectable and "not available"
    _mode('AUTO.EXTERNAL%d' % (n + 1), MAIN_AUTO, SUB_EXTERNAL1 + n, STANDARD_NON_STANDARD, NOT_USER_SELECTABLE,
          '(Mode not available)') for n in range(8))
_STANDARD_BY_CUSTOM = {m.custom_mode: m.standard_mode for m in AVAILABLE_MODES}
_CUSTOM_BY_LABEL = {m.label: m.custom_mode for m in AVAILABLE_MODES}
# For a multicopter the modes PX4 lists with a standard mode are exactly those that
# mode_util::getNavStateFromStandardMode (src/lib/modes/standard_modes.hpp) gives for one
_LABEL_BY_STANDARD = {m.standard_mode: m.label for m in AVAILABLE_MODES if m.standard_mode != STANDARD_NON_STANDARD}


def standard_mode(custom_mode):
    """CURRENT_MODE.standard_mode of a PX4 custom_mode (0, non-standard, for one PX4 does not list)."""
    return _STANDARD_BY_CUSTOM.get(custom_mode, STANDARD_NON_STANDARD)


def mode_of_standard(standard):
    """Our label for a MAV_STANDARD_MODE (PX4's numbering), as DO_SET_STANDARD_MODE maps it for a
    multicopter; None for NON_STANDARD, CRUISE (fixed wing only) and unknown numbers."""
    return _LABEL_BY_STANDARD.get(standard)
