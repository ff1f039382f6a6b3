"""Telemetry of the simulated PX4: the onboard-link streams at PX4's rates, and their messages.

`Streams` keeps one interval per message id (PX4 v1.12 onboard rates by default) and says
which are due; MAV_CMD_SET_MESSAGE_INTERVAL changes an interval, 0 restores the default,
-1 stops a stream. HEARTBEAT is fixed at 1 Hz, as on PX4 (setting it answers FAILED).
`build(name, ...)` makes each message from the vehicle and commander state.
"""

import math
import time

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

MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_PX4 = 2, 12
LANDED_UNDEFINED, LANDED_ON_GROUND, LANDED_IN_AIR, LANDED_TAKEOFF, LANDED_LANDING = 0, 1, 2, 3, 4
# MAV_PROTOCOL_CAPABILITY: mission float/int, param float, command int, set attitude/position
# targets (local and global), MAVLink 2, fence and rally missions
CAPABILITIES = 1 | 2 | 4 | 8 | 64 | 128 | 256 | 8192 | 16384 | 32768
PX4_VERSION = (1 << 24) | (15 << 16) | (0 << 8) | 255  # v1.15.0 release
# MAV_STANDARD_MODE for CURRENT_MODE
STANDARD_MODES = {'POSCTL': 1, 'ALTCTL': 4, 'AUTO.RTL': 5, 'AUTO.MISSION': 6, 'AUTO.LAND': 7, 'AUTO.TAKEOFF': 8}


class Streams:
    def __init__(self, mavlink_module, now_s):
        self._ids = {name: getattr(mavlink_module, 'MAVLINK_MSG_ID_' + name) for name in DEFAULT_RATES_HZ}
        self.names_by_id = {v: k for k, v in self._ids.items()}
        for name in ON_REQUEST:
            self.names_by_id[getattr(mavlink_module, 'MAVLINK_MSG_ID_' + name)] = name
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


def landed_state(commander):
    if commander.vehicle.landed:
        return LANDED_ON_GROUND
    mode = commander.nav_mode
    if mode == 'AUTO.TAKEOFF':
        return LANDED_TAKEOFF
    if mode == 'AUTO.LAND' or (mode == 'AUTO.RTL' and commander.rtl_phase == 'land'):
        return LANDED_LANDING
    return LANDED_IN_AIR


def _pressure_hpa(alt_m):
    return 1013.25 * (1.0 - 2.25577e-5 * alt_m) ** 5.25588


class TelemetryBuilder:
    """Builds the autopilot's messages with `mav` (a pymavlink MAVLink codec)."""

    def __init__(self, mav, commander, frame, params, boot_s):
        self.mav, self.commander, self.frame, self.params = mav, commander, frame, params
        self.boot_s = boot_s
        self.home_set = False

    def time_boot_ms(self, now_s):
        return int((now_s - self.boot_s) * 1000) & 0xFFFFFFFF

    def build(self, name, now_s):
        return getattr(self, '_' + name.lower())(now_s)

    def _heartbeat(self, now_s):
        c = self.commander
        return self.mav.heartbeat_encode(self.params['MAV_TYPE'], MAV_AUTOPILOT_PX4, c.base_mode(),
                                         c.custom_mode(), c.system_status(), 3)

    def current_mode(self):
        c = self.commander
        return self.mav.current_mode_encode(STANDARD_MODES.get(c.nav_mode, 0), c.custom_mode(),
                                            c.intended_custom_mode())

    def _sys_status(self, now_s):
        sensors = 0x1 | 0x2 | 0x4 | 0x8 | 0x20  # gyro, accel, mag, baro, gps
        return self.mav.sys_status_encode(sensors, sensors, sensors, 200, 16200, -1, 100, 0, 0, 0, 0, 0, 0)

    def _attitude_quaternion(self, now_s):
        v = self.commander.vehicle
        w, x, y, z = v.attitude()
        return self.mav.attitude_quaternion_encode(self.time_boot_ms(now_s), w, x, y, z, 0.0, 0.0, v.yaw_rate,
                                                   [0.0, 0.0, 0.0, 0.0])

    def _local_position_ned(self, now_s):
        v = self.commander.vehicle
        return self.mav.local_position_ned_encode(self.time_boot_ms(now_s), *v.position, *v.velocity)

    def _global_position_int(self, now_s):
        v = self.commander.vehicle
        lat, lon, alt = self.frame.to_global(*v.position)
        heading = int(round(math.degrees(v.yaw) * 100.0)) % 36000
        return self.mav.global_position_int_encode(
            self.time_boot_ms(now_s), int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)),
            int(round(v.height() * 1000)), *(int(round(c * 100)) for c in v.velocity), heading)

    def _altitude(self, now_s):
        v = self.commander.vehicle
        amsl = self.frame.alt0 + v.height()
        return self.mav.altitude_encode(int((now_s - self.boot_s) * 1e6), amsl, amsl, v.height(), v.height(),
                                        float('nan'), v.height())

    def _extended_sys_state(self, now_s):
        return self.mav.extended_sys_state_encode(0, landed_state(self.commander))

    def _home_position(self, now_s):
        if not self.home_set:
            return None
        f = self.frame
        return self.mav.home_position_encode(int(round(f.lat0 * 1e7)), int(round(f.lon0 * 1e7)),
                                             int(round(f.alt0 * 1000)), 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0],
                                             0.0, 0.0, 0.0, int(time.time() * 1e6))

    def _highres_imu(self, now_s):
        v = self.commander.vehicle
        ax, ay, az = v.specific_force_body()
        c, s = math.cos(v.yaw), math.sin(v.yaw)
        mag_n, mag_d = 0.21, 0.43  # gauss, roughly central Europe
        alt = self.frame.alt0 + v.height()
        return self.mav.highres_imu_encode(int((now_s - self.boot_s) * 1e6), ax, ay, az, 0.0, 0.0, v.yaw_rate,
                                           c * mag_n, -s * mag_n, mag_d, _pressure_hpa(alt), 0.0, alt, 25.0,
                                           0x1FFF)

    def _mission_current(self, now_s):
        runner = self.commander.runner
        return self.mav.mission_current_encode(runner.seq, len(runner.items))

    def _autopilot_version(self, now_s):
        return self.mav.autopilot_version_encode(CAPABILITIES, PX4_VERSION, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8,
                                                 0x26AC, 0x11, self.mav.srcSystem)

    def statustext(self, severity, text):
        return self.mav.statustext_encode(severity, text.encode('ascii', 'replace')[:50])

