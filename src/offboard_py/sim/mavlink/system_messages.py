"""The simulated PX4's identity and system messages as PX4's streams fill them (src/modules/mavlink/streams/
AUTOPILOT_VERSION.hpp, PROTOCOL_VERSION in mavlink_main.cpp, SYSTEM_TIME.hpp, OPEN_DRONE_ID_LOCATION.hpp,
OPEN_DRONE_ID_SYSTEM.hpp, GPS_GLOBAL_ORIGIN.hpp): a part of sim.mavlink.messages.TelemetryBuilder."""

import math
import time

from offboard_py.dialect import mavlink

# GPS_GLOBAL_ORIGIN: PX4's estimator set its origin 0.636 and 0.644 s after boot in the two real-PX4
# recordings (the message's time_usec, reference/conversations/takeoff-*-px4); before that PX4's stream
# has nothing to send, and REQUEST_MESSAGE for it is DENIED. The stream sends it again only when the
# origin changes, which it did not in either flight (one each, arming and takeoff included).
ORIGIN_SET_S = 0.64
# AUTOPILOT_VERSION as PX4 main's (0xE8FF)
CAPABILITIES = (mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE | mavlink.MAV_PROTOCOL_CAPABILITY_FTP
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | mavlink.MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY)
PX4_VERSION = 0xFF  # flight_sw_version of PX4 SITL's dev build: no release number, type byte 0xFF
# AUTOPILOT_VERSION's other fields as the recorded build sent them (reference/px4-sitl-autopilot-version.json):
# the middleware's version as the flight stack's, the host's OS version, board 1, and PX4's git hash
# (02e73e3b6f, little-endian in the last five of eight bytes) as the flight and middleware custom version
PX4_OS_SW_VERSION = 101854463
PX4_BOARD_VERSION = 1
PX4_CUSTOM_VERSION = [0, 0, 0, 0x6F, 0x3B, 0x3E, 0xE7, 0x02]
MAVLINK_LIBRARY_HASH = bytes.fromhex('6521d1aee97ea451')  # PROTOCOL_VERSION.library_version_hash, wire order
UID_BASE = int.from_bytes(b'PX4SITL\0', 'big')  # + system id: 64 bits, stable per instance
UNIX_2019_S = 1546300800  # OPEN_DRONE_ID_SYSTEM.timestamp counts from 2019-01-01 00:00 UTC


class SystemMessages:
    """AUTOPILOT_VERSION, PROTOCOL_VERSION, SYSTEM_TIME, OPEN_DRONE_ID_LOCATION/SYSTEM and GPS_GLOBAL_ORIGIN."""

    def _system_time(self, st, now_s):
        return self.mav.system_time_encode(int(time.time() * 1e6), self.time_boot_ms(now_s))

    def _open_drone_id_location(self, st, now_s):
        lat, lon, _ = self._global(st)
        speed, course = self._course(st)
        amsl = self._amsl(st)
        status = (mavlink.MAV_ODID_STATUS_GROUND if st.landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND
                  else mavlink.MAV_ODID_STATUS_AIRBORNE)
        direction = 36100 if course is None else int(round(math.degrees(course) * 100.0)) % 36000
        return self.mav.open_drone_id_location_encode(
            0, 0, [0] * 20, status, direction, min(int(round(speed * 100)), 25425),
            max(-6200, min(6200, int(round(-st.velocity[2] * 100)))), lat, lon, amsl, amsl,
            mavlink.MAV_ODID_HEIGHT_REF_OVER_TAKEOFF, st.height, mavlink.MAV_ODID_HOR_ACC_1_METER,
            mavlink.MAV_ODID_VER_ACC_1_METER, mavlink.MAV_ODID_VER_ACC_1_METER,
            mavlink.MAV_ODID_SPEED_ACC_0_3_METERS_PER_SECOND, round(time.time() % 3600.0, 1),
            mavlink.MAV_ODID_TIME_ACC_0_1_SECOND)

    def _open_drone_id_system(self, st, now_s):
        f = self.origin
        return self.mav.open_drone_id_system_encode(
            0, 0, [0] * 20, mavlink.MAV_ODID_OPERATOR_LOCATION_TYPE_TAKEOFF,
            mavlink.MAV_ODID_CLASSIFICATION_TYPE_UNDECLARED, int(round(f.lat0 * 1e7)), int(round(f.lon0 * 1e7)),
            1, 0, -1000.0, -1000.0, mavlink.MAV_ODID_CATEGORY_EU_UNDECLARED, mavlink.MAV_ODID_CLASS_EU_UNDECLARED,
            f.alt0, int(time.time()) - UNIX_2019_S)

    def _gps_global_origin(self, st, now_s):
        """The estimator's origin (sim.geo.GeoOrigin), as PX4's GPS_GLOBAL_ORIGIN stream fills it:
        degE7, mm AMSL, time_usec the boot time the origin was set; None before it is."""
        if now_s < ORIGIN_SET_S:
            return None
        return self.mav.gps_global_origin_encode(int(round(self.origin.lat0 * 1e7)), int(round(self.origin.lon0 * 1e7)),
                                                 int(round(self.origin.alt0 * 1000)), int(ORIGIN_SET_S * 1e6))

    def _autopilot_version(self, st, now_s):
        return self.mav.autopilot_version_encode(CAPABILITIES, PX4_VERSION, PX4_VERSION, PX4_OS_SW_VERSION,
                                                 PX4_BOARD_VERSION, PX4_CUSTOM_VERSION, PX4_CUSTOM_VERSION, [0] * 8,
                                                 0, 0, self.uid)

    def _protocol_version(self, st, now_s):
        """As PX4 SITL answers (reference/px4-sitl-measured.md, "Turn 3 recordings", section 4):
        MAVLink 2 (200), min 100, max 203, no spec hash (all zero), and the library hash of the
        mavlink submodule PX4 was built with (its commit as a little-endian uint64, wire order)."""
        return self.mav.protocol_version_encode(200, 100, 203, [0] * 8, list(MAVLINK_LIBRARY_HASH))
