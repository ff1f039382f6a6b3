"""The vehicle commands of the simulated PX4: each COMMAND_LONG/COMMAND_INT the receiver passes on, read as
PX4's commander and navigator read a vehicle_command (Commander::handle_command, navigator_main.cpp), and
answered with the flight stack's MAV_RESULT. What the receiver answers itself (message intervals and
requests) is sim.mavlink.receiver's; the checks before a command gets here too.

A handler is handler(msg, now_s) -> MAV_RESULT, or None when PX4 sends no answer."""

import math

from offboard_py import px4_modes
from offboard_py.dialect import ARM_DISARM_FORCE_MAGIC, MAV_CMD_DO_ORBIT, MAV_CMD_INJECT_FAILURE, mavlink

ACCEPTED, DENIED, FAILED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_FAILED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED


def command_position(msg):
    """(param5, param6, param7) as PX4's receiver puts a COMMAND_LONG or COMMAND_INT into its vehicle
    command: COMMAND_INT's x and y in 1e-7 deg, both INT32_MAX meaning "not given" (NaN), z as param7."""
    if msg.get_type() != 'COMMAND_INT':
        return msg.param5, msg.param6, msg.param7
    if msg.x == msg.y == 0x7FFFFFFF:
        return math.nan, math.nan, msg.z
    return msg.x / 1e7, msg.y / 1e7, msg.z


def c_int_round(value):
    """(int)(value + 0.5f) as PX4's receiver reads a message id from a float parameter; None where C
    leaves it undefined (NaN, infinities, out of int's range)."""
    if not math.isfinite(value) or abs(value) >= 2.0 ** 31:
        return None
    return int(value + 0.5)  # Python's int() truncates towards zero, as the C cast


def lroundf_int8(value, bits=8):
    """static_cast<int8_t>(lroundf(value)) as PX4 SITL computes it on x86-64 (`bits` 32: the int cast):
    halves round away from zero; NaN, infinities and values past a long give LONG_MIN, whose low bits
    are 0; the cast keeps the low `bits`, signed."""
    if not math.isfinite(value) or abs(value) >= 2.0 ** 63:
        return 0
    n = int(math.floor(abs(value) + 0.5)) * (1 if value >= 0 else -1)
    half = 1 << (bits - 1)
    return (n + half) % (1 << bits) - half


class VehicleCommands:
    """The command table {MAV_CMD: handler} of `px4`'s flight stack (sim.autopilot.SimulatedPx4)."""

    def __init__(self, px4):
        self.flight, self.origin, self.params = px4.flight, px4.origin, px4.params
        self.table = {
            mavlink.MAV_CMD_DO_SET_MODE: self._set_mode,
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm,
            mavlink.MAV_CMD_NAV_TAKEOFF: self._takeoff,
            mavlink.MAV_CMD_NAV_LAND: lambda msg, now: self.flight.request_mode('AUTO.LAND', now),
            mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda msg, now: self.flight.return_to_launch(now),
            mavlink.MAV_CMD_MISSION_START: self._mission_start,
            mavlink.MAV_CMD_DO_REPOSITION: self._reposition,
            mavlink.MAV_CMD_DO_CHANGE_ALTITUDE: self._change_altitude,
            mavlink.MAV_CMD_DO_SET_STANDARD_MODE: self._set_standard_mode,
            MAV_CMD_DO_ORBIT: lambda msg, now: self.flight.request_mode('POSCTL.ORBIT', now),
            mavlink.MAV_CMD_DO_FLIGHTTERMINATION: self._flight_termination,
            mavlink.MAV_CMD_DO_SET_HOME: self._set_home,
            mavlink.MAV_CMD_RUN_PREARM_CHECKS: lambda msg, now: ACCEPTED,
            MAV_CMD_INJECT_FAILURE: self._inject_failure,
        }

    def _set_mode(self, msg, now):
        if not all(map(math.isfinite, (msg.param1, msg.param2, msg.param3))):
            return DENIED
        return self.flight.request_base_mode(int(msg.param1), msg.param2, msg.param3, now)

    def _arm_disarm(self, msg, now):
        """Commander::handle_command reads param1 and param2 with lroundf (halves away from zero): 0.5
        arms, 0.4 disarms; any other action is 'Unsupported ARM_DISARM param' and the result stays
        UNSUPPORTED. The force magic is lroundf(param2) == 21196."""
        action = lroundf_int8(msg.param1)
        if action not in (0, 1):
            return UNSUPPORTED
        return self.flight.request_arming(action == 1, lroundf_int8(msg.param2, bits=32) == ARM_DISARM_FORCE_MAGIC,
                                          now)

    def _takeoff(self, msg, now):
        return self.flight.takeoff(command_position(msg)[2], self.origin.alt0, now)

    def _reposition(self, msg, now):
        """DO_REPOSITION (MAVSDK's goto_location, QGroundControl's "go to location"): param2 must ask
        for the mode change (bit 0) and nothing else, or PX4 answers UNSUPPORTED; latitude and
        longitude (COMMAND_INT: x, y in 1e-7 deg) and the altitude AMSL each NaN for "as now";
        param1 the ground speed (none: MPC_XY_CRUISE), param4 the yaw (NaN: as now)."""
        flags = int(msg.param2) if math.isfinite(msg.param2) else 0
        if not flags & 1 or flags & ~1:
            return UNSUPPORTED
        lat, lon, alt = command_position(msg)
        v = self.flight.vehicle
        north, east, down = v.position
        if math.isfinite(lat) and math.isfinite(lon):
            north, east, _ = self.origin.to_local(lat, lon, self.origin.alt0)
        if math.isfinite(alt):
            down = self.origin.alt0 - alt
        speed = msg.param1 if math.isfinite(msg.param1) and msg.param1 > 0 else None
        return self.flight.reposition((north, east, down), speed, msg.param4, now)

    def _change_altitude(self, msg, now):
        """DO_CHANGE_ALTITUDE: AUTO.LOITER (Commander::handle_command), and to PX4's navigator a
        DO_REPOSITION with only the altitude: param1 AMSL (NaN: as now), kept only while armed
        (navigator_main.cpp)."""
        north, east, down = self.flight.vehicle.position
        if math.isfinite(msg.param1):
            down = self.origin.alt0 - msg.param1
        return self.flight.reposition((north, east, down), None, math.nan, now)

    def _set_standard_mode(self, msg, now):
        """DO_SET_STANDARD_MODE: roundf(param1) through mode_util::getNavStateFromStandardMode; a
        standard mode a multicopter has no mode for is FAILED, the mode change's answer otherwise."""
        mode = px4_modes.mode_of_standard(int(round(msg.param1))) if math.isfinite(msg.param1) else None
        if mode is None:
            return FAILED
        return self.flight.request_mode(mode, now)

    def _flight_termination(self, msg, now):
        """Commander::handle_command: DENIED unless param1 > 0.5 and armed."""
        return self.flight.terminate(now) if msg.param1 > 0.5 else DENIED

    def _set_home(self, msg, now):
        """Commander::handle_command with COM_HOME_EN: param1 > 0.5 the current position; else the
        latitude, longitude and altitude AMSL given (DENIED unless all are finite). COM_HOME_EN 0: DENIED."""
        if not self.params['COM_HOME_EN']:
            return DENIED
        if msg.param1 > 0.5:
            return self.flight.set_home(None, now)
        lat, lon, alt = command_position(msg)
        if not all(map(math.isfinite, (lat, lon, alt))):
            return DENIED
        return self.flight.set_home(self.origin.to_local(lat, lon, alt), now)

    def _mission_start(self, msg, now):
        first = int(msg.param1) if math.isfinite(msg.param1) and msg.param1 >= 0 else 0
        return self.flight.start_mission(first, now)

    def _inject_failure(self, msg, now):
        """PX4's receiver: DENIED unless SYS_FAILURE_EN=1; then the module that takes the unit answers
        (sim.failures), and None (no COMMAND_ACK) when none does, as PX4 SITL."""
        if not self.params['SYS_FAILURE_EN']:
            return DENIED
        if not all(map(math.isfinite, (msg.param1, msg.param2, msg.param3))):
            return None
        taken = self.flight.inject_failure(*(int(round(p)) for p in (msg.param1, msg.param2, msg.param3)), now)
        return None if taken is None else (ACCEPTED if taken else UNSUPPORTED)
