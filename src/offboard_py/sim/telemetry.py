"""Telemetry of the simulated PX4: the onboard-link streams at PX4's rates, and their messages.

`Streams` keeps one interval per message id (PX4 v1.12 onboard rates by default) and says
which are due; MAV_CMD_SET_MESSAGE_INTERVAL changes an interval, 0 restores the default,
-1 stops a stream. HEARTBEAT is fixed at 1 Hz, as on PX4 (setting it answers FAILED).
`TelemetryBuilder.build(name, status, now_s)` makes each message from the flight's read-only
Status (sim.flight); it never sees the commander or the vehicle model.
"""

import math
import time

from offboard_py.dialect import mavlink

# Onboard link rates (Hz) of PX4 v1.12
DEFAULT_RATES_HZ = {
    'HEARTBEAT': 1.0,
    'SYS_STATUS': 1.0,
    'ATTITUDE_QUATERNION': 50.0,
    'GLOBAL_POSITION_INT': 50.0,
    'LOCAL_POSITION_NED': 30.0,
    'HIGHRES_IMU': 50.0,
    'ALTITUDE': 10.0,
    'EXTENDED_SYS_STATE': 5.0,
    'HOME_POSITION': 0.5,
    'MISSION_CURRENT': 1.0,
}
FIXED_RATE = frozenset(('HEARTBEAT',))
# One-shot messages that MAV_CMD_REQUEST_MESSAGE can ask for besides the streams
ON_REQUEST = frozenset(('AUTOPILOT_VERSION',))

# MAV_PROTOCOL_CAPABILITY bits we announce
CAPABILITIES = (mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY)
PX4_VERSION = (1 << 24) | (15 << 16) | (0 << 8) | 255  # v1.15.0 release
# MAV_STANDARD_MODE for CURRENT_MODE
STANDARD_MODES = {'POSCTL': mavlink.MAV_STANDARD_MODE_POSITION_HOLD, 'ALTCTL': mavlink.MAV_STANDARD_MODE_ALTITUDE_HOLD,
                  'AUTO.RTL': mavlink.MAV_STANDARD_MODE_RETURN_HOME, 'AUTO.MISSION': mavlink.MAV_STANDARD_MODE_MISSION,
                  'AUTO.LAND': mavlink.MAV_STANDARD_MODE_LAND, 'AUTO.TAKEOFF': mavlink.MAV_STANDARD_MODE_TAKEOFF}
# What SYS_STATUS reports present, enabled and healthy
SENSORS = (mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
           | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
           | mavlink.MAV_SYS_STATUS_SENSOR_GPS)
HIGHRES_IMU_ALL_FIELDS = 0x1FFF  # fields_updated: every one of the 13 fields is fresh


class Streams:
    def __init__(self, now_s):
        self._ids = {name: getattr(mavlink, 'MAVLINK_MSG_ID_' + name) for name in DEFAULT_RATES_HZ}
        self.names_by_id = {v: k for k, v in self._ids.items()}
        for name in ON_REQUEST:
            self.names_by_id[getattr(mavlink, 'MAVLINK_MSG_ID_' + name)] = name
        self.interval_s = {name: 1.0 / hz for name, hz in DEFAULT_RATES_HZ.items()}
        self.next_s = {name: now_s for name in DEFAULT_RATES_HZ}

    def set_interval(self, msg_id, interval_us, now_s):
        """Apply SET_MESSAGE_INTERVAL; True when accepted."""
        name = self.names_by_id.get(int(msg_id))
        if name is None or name in FIXED_RATE or name in ON_REQUEST:
            return False
        if interval_us == 0:
            self.interval_s[name] = 1.0 / DEFAULT_RATES_HZ[name]
        elif interval_us < 0:
            self.interval_s[name] = None
        else:
            self.interval_s[name] = interval_us * 1e-6
        self.next_s[name] = now_s
        return True

    def interval_us(self, msg_id):
        """For MESSAGE_INTERVAL: -1 stopped, 0 unknown/not available, else microseconds."""
        name = self.names_by_id.get(int(msg_id))
        if name is None or name in ON_REQUEST:
            return 0
        interval = self.interval_s[name]
        return -1 if interval is None else int(interval * 1e6)

    def due(self, now_s):
        """Names of the streams to send now; their next times move on."""
        out = []
        for name, interval in self.interval_s.items():
            if interval is not None and now_s >= self.next_s[name]:
                out.append(name)
                # keep the cadence, but never queue a burst after a stall
                self.next_s[name] = max(self.next_s[name] + interval, now_s + interval * 0.5)
        return out


def _pressure_hpa(alt_m):
    return 1013.25 * (1.0 - 2.25577e-5 * alt_m) ** 5.25588


class TelemetryBuilder:
    """Builds the autopilot's messages with `mav` (a pymavlink codec) from a flight Status."""

    def __init__(self, mav, frame, params, boot_s=0.0):
        self.mav, self.frame, self.params = mav, frame, params
        self.boot_s = boot_s

    def time_boot_ms(self, now_s):
        return int((now_s - self.boot_s) * 1000) & 0xFFFFFFFF

    def time_usec(self, now_s):
        return int((now_s - self.boot_s) * 1e6)

    def build(self, name, status, now_s):
        """The message `name` for now, or None when there is nothing to say (no home yet)."""
        return getattr(self, '_' + name.lower())(status, now_s)

    def _heartbeat(self, st, now_s):
        return self.mav.heartbeat_encode(self.params['MAV_TYPE'], mavlink.MAV_AUTOPILOT_PX4, st.base_mode,
                                         st.custom_mode, st.system_status, 3)

    def current_mode(self, st):
        return self.mav.current_mode_encode(STANDARD_MODES.get(st.nav_mode, mavlink.MAV_STANDARD_MODE_NON_STANDARD),
                                            st.custom_mode, st.intended_custom_mode)

    def _sys_status(self, st, now_s):
        return self.mav.sys_status_encode(SENSORS, SENSORS, SENSORS, 200, 16200, -1, 100, 0, 0, 0, 0, 0, 0)

    def _attitude_quaternion(self, st, now_s):
        w, x, y, z = st.attitude
        return self.mav.attitude_quaternion_encode(self.time_boot_ms(now_s), w, x, y, z, 0.0, 0.0, st.yaw_rate,
                                                   [0.0, 0.0, 0.0, 0.0])

    def _local_position_ned(self, st, now_s):
        return self.mav.local_position_ned_encode(self.time_boot_ms(now_s), *st.position, *st.velocity)

    def _global_position_int(self, st, now_s):
        lat, lon, alt = self.frame.to_global(*st.position)
        heading = int(round(math.degrees(st.yaw) * 100.0)) % 36000
        return self.mav.global_position_int_encode(
            self.time_boot_ms(now_s), int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)),
            int(round(st.height * 1000)), *(int(round(c * 100)) for c in st.velocity), heading)

    def _altitude(self, st, now_s):
        amsl = self.frame.alt0 + st.height
        return self.mav.altitude_encode(self.time_usec(now_s), amsl, amsl, st.height, st.height, float('nan'),
                                        st.height)

    def _extended_sys_state(self, st, now_s):
        return self.mav.extended_sys_state_encode(mavlink.MAV_VTOL_STATE_UNDEFINED, st.landed_state)

    def _home_position(self, st, now_s):
        if not st.ready:  # PX4 sets home once the estimator is good
            return None
        f = self.frame
        return self.mav.home_position_encode(int(round(f.lat0 * 1e7)), int(round(f.lon0 * 1e7)),
                                             int(round(f.alt0 * 1000)), 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0],
                                             0.0, 0.0, 0.0, int(time.time() * 1e6))

    def _highres_imu(self, st, now_s):
        ax, ay, az = st.specific_force
        c, s = math.cos(st.yaw), math.sin(st.yaw)
        mag_n, mag_d = 0.21, 0.43  # gauss, roughly central Europe
        alt = self.frame.alt0 + st.height
        return self.mav.highres_imu_encode(self.time_usec(now_s), ax, ay, az, 0.0, 0.0, st.yaw_rate,
                                           c * mag_n, -s * mag_n, mag_d, _pressure_hpa(alt), 0.0, alt, 25.0,
                                           HIGHRES_IMU_ALL_FIELDS)

    def _mission_current(self, st, now_s):
        return self.mav.mission_current_encode(st.mission_seq, st.mission_count)

    def _autopilot_version(self, st, now_s):
        return self.mav.autopilot_version_encode(CAPABILITIES, PX4_VERSION, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8,
                                                 0x26AC, 0x11, self.mav.srcSystem)

    def statustext(self, severity, text):
        return self.mav.statustext_encode(severity, text.encode('ascii', 'replace')[:50])
