"""PX4 flight modes on MAVLink: custom_mode <-> mode string, and the HEARTBEAT base_mode flags.

PX4 packs its mode into HEARTBEAT.custom_mode as main_mode << 16 | sub_mode << 24.
The strings are mavros's (AUTO.LOITER, OFFBOARD, ...). Used by the bridge (to name
modes) and by the simulated PX4 (to encode them), so both agree by construction.
"""

from offboard_py.dialect import mavlink

# PX4 main modes (px4_custom_mode.h; PX4's own enums, not MAVLink's)
MAIN_MANUAL, MAIN_ALTCTL, MAIN_POSCTL, MAIN_AUTO, MAIN_ACRO, MAIN_OFFBOARD, MAIN_STABILIZED, MAIN_RATTITUDE = range(1, 9)
# PX4 AUTO sub-modes (px4_custom_mode.h)
SUB_READY, SUB_TAKEOFF, SUB_LOITER, SUB_MISSION, SUB_RTL, SUB_LAND, SUB_RTGS, SUB_FOLLOW_TARGET, SUB_PRECLAND = range(1, 10)

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

# Modes a pilot flies with sticks: PX4 sets MANUAL_INPUT for them and they need RC.
MANUAL_MODES = frozenset(('MANUAL', 'ALTCTL', 'POSCTL', 'ACRO', 'STABILIZED', 'RATTITUDE'))


def encode(mode):
    """custom_mode for a mode string; KeyError for an unknown one."""
    return join(*MODES[mode])


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
    elif mode == 'OFFBOARD':
        flags |= mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
    return flags
