"""Which modes PX4 has and what a mode request names, as PX4's commander/ModeUtil (mode_requirements.cpp)
and Commander::handle_command's DO_SET_MODE branch take them (PX4 main 02e73e3b6f). Pure tables."""

from offboard_py import px4_modes
from offboard_py.dialect import mavlink

# names mavros knows (px4_modes.MODES) for which PX4 main has no navigation state
REFUSED_MODES = frozenset(('AUTO.READY', 'AUTO.RTGS', 'RATTITUDE'))
# modes that prevent arming (ModeUtil/mode_requirements.cpp: mode_req_prevent_arming)
NOT_ARMABLE = frozenset(('AUTO.LAND', 'AUTO.RTL', 'AUTO.FOLLOW_TARGET', 'AUTO.PRECLAND', 'TERMINATION'))
# modes the vehicle leaves for the user's previous choice once it is disarmed: those that prevent
# arming and the takeoff, TERMINATION excepted (UserModeIntention::change, _nav_state_after_disarming)
TRANSIENT_MODES = (NOT_ARMABLE | {'AUTO.TAKEOFF'}) - {'TERMINATION'}
# DO_SET_MODE's custom main modes (px4_custom_mode.h) as Commander::handle_command takes them; POSCTL
# and AUTO have their own rules in set_mode_target
_MAIN_MODES = {px4_modes.MAIN_MANUAL: 'MANUAL', px4_modes.MAIN_ALTCTL: 'ALTCTL',
               px4_modes.MAIN_ALTITUDE_CRUISE: 'ALTITUDE_CRUISE', px4_modes.MAIN_ACRO: 'ACRO',
               px4_modes.MAIN_STABILIZED: 'STABILIZED', px4_modes.MAIN_OFFBOARD: 'OFFBOARD'}
_AUTO_SUB_MODES = {px4_modes.SUB_LOITER: 'AUTO.LOITER', px4_modes.SUB_MISSION: 'AUTO.MISSION',
                   px4_modes.SUB_RTL: 'AUTO.RTL', px4_modes.SUB_TAKEOFF: 'AUTO.TAKEOFF',
                   px4_modes.SUB_LAND: 'AUTO.LAND', px4_modes.SUB_FOLLOW_TARGET: 'AUTO.FOLLOW_TARGET',
                   px4_modes.SUB_PRECLAND: 'AUTO.PRECLAND'}
# lib/modes/ui.hpp nav_state_names: how PX4's texts name a mode
NAV_STATE_NAMES = {'MANUAL': 'Manual', 'ALTCTL': 'Altitude', 'POSCTL': 'Position', 'AUTO.MISSION': 'Mission',
                   'AUTO.LOITER': 'Hold', 'AUTO.RTL': 'Return', 'POSCTL.SLOW': 'Position Slow',
                   'ALTITUDE_CRUISE': 'Altitude Cruise', 'ACRO': 'Acro', 'DESCEND': 'Descend',
                   'TERMINATION': 'Termination', 'OFFBOARD': 'Offboard', 'STABILIZED': 'Stabilized',
                   'AUTO.TAKEOFF': 'Takeoff', 'AUTO.LAND': 'Land', 'AUTO.FOLLOW_TARGET': 'Follow Target',
                   'AUTO.PRECLAND': 'Precision Landing', 'POSCTL.ORBIT': 'Orbit', 'AUTO.VTOL_TAKEOFF': 'VTOL Takeoff'}
# PX4's Descend (a landing without a position) is AUTO.LAND on MAVLink (px4_custom_mode.h); flown as the landing
FLOWN_AS = {'DESCEND': 'AUTO.LAND'}


def set_mode_target(base_mode, main_mode, sub_mode):
    """(mode, None) for DO_SET_MODE's base_mode, custom main and sub mode (SET_MODE's too), or
    (None, PX4's text) when PX4 has no such mode, as Commander::handle_command's DO_SET_MODE branch:
    each field cast to a byte; POSCTL with sub mode 2 is Position Slow and with any other POSCTL
    itself (ORBIT, 1, is not reached this way); AUTO with sub mode 0 is the mission, READY, RTGS,
    VTOL_TAKEOFF (a multicopter) and unknown sub modes are refused, as are the main modes
    RATTITUDE (8), SIMPLE (9), TERMINATION (10) and unknown ones. Without the custom mode flag, the
    base mode's flags choose a mission, POSCTL, STABILIZED or MANUAL. The external modes (AUTO
    11-18) are refused: none is registered here."""
    base_mode, main_mode, sub_mode = int(base_mode) & 0xFF, int(main_mode) & 0xFF, int(sub_mode) & 0xFF
    if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
        if base_mode & mavlink.MAV_MODE_FLAG_AUTO_ENABLED:
            return 'AUTO.MISSION', None
        if base_mode & mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED:
            if base_mode & mavlink.MAV_MODE_FLAG_GUIDED_ENABLED:
                return 'POSCTL', None
            if base_mode & mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED:
                return 'STABILIZED', None
            return 'MANUAL', None
        return None, 'Unsupported base mode\t'
    if main_mode == px4_modes.MAIN_POSCTL:
        return ('POSCTL.SLOW' if sub_mode == px4_modes.SUB_POSCTL_SLOW else 'POSCTL'), None
    if main_mode == px4_modes.MAIN_AUTO:
        if sub_mode == 0:
            return 'AUTO.MISSION', None
        mode = _AUTO_SUB_MODES.get(sub_mode)
        return (mode, None) if mode else (None, 'Unsupported auto mode\t')
    mode = _MAIN_MODES.get(main_mode)
    return (mode, None) if mode else (None, 'Unsupported main mode\t')
