"""Telemetry of the simulated PX4: PX4's streams and rates per link, and their messages.

`Streams` keeps one interval per message a link sends (`ONBOARD_RATES_HZ`: PX4's "onboard"
mode, as measured on PX4 SITL's offboard-API link; `GCS_RATES_HZ`: SITL's ground-station link,
as measured) and says which are due. MAV_CMD_SET_MESSAGE_INTERVAL
changes an interval for any message the simulator can build, 0 restores the link's default
(which may be off), -1 stops it. HEARTBEAT is fixed at 1 Hz, as on PX4 (setting it answers
FAILED).
`TelemetryBuilder.build(name, status, now_s)` makes each message from the flight's read-only
Status (sim.flight); it never sees the commander or the vehicle model. What several messages
share (global position, Euler angles) is computed once per Status, i.e. once per step.
LINK_NODE_STATUS is each link's own (`link_node_status`, from its counters). Not sent: PX4's
EVENT / CURRENT_EVENT_SEQUENCE (its event interface, whose texts live in PX4's own metadata).
"""

import math
import struct
import time

from offboard_py import dialect, px4_modes, wire
from offboard_py.dialect import mavlink
from offboard_py.sim.navigator import rtl_time_estimate
from offboard_py.sim.vehicle import quaternion_from_thrust

# PX4's MAVLINK_MODE_ONBOARD (mavlink_main.cpp) at the rates PX4 SITL sends on its onboard link
# (reference/px4-sitl-census.json, e.g. 98.5 measured for the 100 Hz ATTITUDE stream;
# GPS_RAW_INT follows the simulated GPS: 8 Hz)
ONBOARD_RATES_HZ = {
    'HEARTBEAT': 1.0,
    'ATTITUDE': 100.0,
    'ATTITUDE_QUATERNION': 50.0,
    'GLOBAL_POSITION_INT': 50.0,
    'HIGHRES_IMU': 50.0,
    'LOCAL_POSITION_NED': 30.0,
    'ODOMETRY': 30.0,
    'TIMESYNC': 10.0,
    'ATTITUDE_TARGET': 10.0,
    'POSITION_TARGET_LOCAL_NED': 10.0,
    # only while armed in an AUTO mode (the navigator's setpoint): 9.9/s from the failsafe's return to the
    # disarm in reference/conversations, none on the ground, in OFFBOARD or after the disarm
    'POSITION_TARGET_GLOBAL_INT': 10.0,
    'ALTITUDE': 10.0,
    'VFR_HUD': 10.0,
    'SERVO_OUTPUT_RAW': 10.0,
    'DISTANCE_SENSOR': 10.0,
    'GPS_RAW_INT': 8.0,
    'SYS_STATUS': 5.0,
    'EXTENDED_SYS_STATE': 5.0,
    'MISSION_CURRENT': 1.0,
    'ESTIMATOR_STATUS': 1.0,
    'SYSTEM_TIME': 1.0,
    'PING': 1.0,
    'SCALED_PRESSURE': 1.0,
    'OPEN_DRONE_ID_LOCATION': 1.0,
    'OPEN_DRONE_ID_SYSTEM': 1.0,
    'LINK_NODE_STATUS': 1.0,
    'HOME_POSITION': 0.5,
    'BATTERY_STATUS': 0.5,
    'VIBRATION': 0.5,
    'CURRENT_MODE': 0.5,
    'TIME_ESTIMATE_TO_TARGET': 0.5,  # configured at 1 Hz, sent on each of the navigator's 2 s updates
    'RC_CHANNELS': 20.0,  # only with an RC link (sim_px4.py --rc): PX4 sends it when input_rc updates
}
# PX4 SITL's GCS link (UDP 18570 -> 14550) as measured (reference/px4-sitl-gcs-census.json, reference/
# px4-sitl-measured.md, "Turn 3 recordings", section 5): PX4's "normal" mode with the seven streams that
# px4-rc.mavlink sets with `mavlink stream -r 50` (49.5 measured), SYS_STATUS and EXTENDED_SYS_STATE at 1 Hz;
# no HIGHRES_IMU, ODOMETRY, TIMESYNC or SYSTEM_TIME. RC_CHANNELS (20 Hz there) only with an RC link (--rc).
GCS_RATES_HZ = {
    'HEARTBEAT': 1.0,
    'ATTITUDE': 50.0,
    'ATTITUDE_QUATERNION': 50.0,
    'ATTITUDE_TARGET': 50.0,
    'GLOBAL_POSITION_INT': 50.0,
    'LOCAL_POSITION_NED': 50.0,
    'POSITION_TARGET_LOCAL_NED': 50.0,
    'SERVO_OUTPUT_RAW': 50.0,
    'GPS_RAW_INT': 5.0,
    'VFR_HUD': 4.0,
    'SYS_STATUS': 1.0,
    'EXTENDED_SYS_STATE': 1.0,
    'ALTITUDE': 1.0,
    'MISSION_CURRENT': 1.0,
    'SCALED_PRESSURE': 1.0,
    'LINK_NODE_STATUS': 1.0,
    'OPEN_DRONE_ID_LOCATION': 1.0,
    'OPEN_DRONE_ID_SYSTEM': 1.0,
    'BATTERY_STATUS': 0.5,
    'CURRENT_MODE': 0.5,
    'DISTANCE_SENSOR': 0.5,
    'ESTIMATOR_STATUS': 0.5,
    'HOME_POSITION': 0.5,
    'TIME_ESTIMATE_TO_TARGET': 0.5,
    'PING': 0.1,
    'VIBRATION': 0.1,
    'RC_CHANNELS': 20.0,
}
FIXED_RATE = frozenset(('HEARTBEAT',))
# Streams PX4 sends only when their data updates, so no interval makes them faster than this (s)
UPDATE_PERIOD_S = {'GPS_RAW_INT': 1.0 / 8.0,              # the simulated GPS: 8 Hz
                   'TIME_ESTIMATE_TO_TARGET': 2.0}        # navigator: rtl_time_estimate every 2 s
# Messages of one link's own state, built for each link that sends them
PER_LINK = frozenset(('LINK_NODE_STATUS',))
# One-shot messages that MAV_CMD_REQUEST_MESSAGE can ask for besides the streams
ON_REQUEST = frozenset(('AUTOPILOT_VERSION', 'PROTOCOL_VERSION', 'GPS_GLOBAL_ORIGIN'))
# GPS_GLOBAL_ORIGIN: PX4's estimator set its origin 0.636 and 0.644 s after boot in the two real-PX4
# recordings (the message's time_usec, reference/conversations/takeoff-*-px4); before that PX4's stream
# has nothing to send, and REQUEST_MESSAGE for it is DENIED. The stream sends it again only when the
# origin changes, which it did not in either flight (one each, arming and takeoff included).
ORIGIN_SET_S = 0.64
# PX4's STATUSTEXT stream sends a text of its log queue (mavlink_log: char[127], so 126 characters) in
# chunks of STATUSTEXT.text's 50 bytes (streams/STATUSTEXT.hpp)
STATUSTEXT_MAX_CHARS = 126
STATUSTEXT_CHUNK_BYTES = 50
# Every message the builder makes: what SET_MESSAGE_INTERVAL and REQUEST_MESSAGE accept
STREAMABLE = frozenset(ONBOARD_RATES_HZ) | frozenset(GCS_RATES_HZ)
NAMES_BY_ID = {getattr(mavlink, 'MAVLINK_MSG_ID_' + name): name for name in STREAMABLE | ON_REQUEST}

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
# SYS_STATUS as PX4 SITL (SIH quadrotor) reports it: present 0x0300402F, enabled 0x0301402F,
# health 0x1320C83F with PREARM_CHECK while the arming checks pass
SENSORS_PRESENT = (mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                   | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                   | mavlink.MAV_SYS_STATUS_SENSOR_GPS | mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
                   | mavlink.MAV_SYS_STATUS_LOGGING | mavlink.MAV_SYS_STATUS_SENSOR_BATTERY)
SENSORS_ENABLED = SENSORS_PRESENT | mavlink.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
LOGGING_BITS = mavlink.MAV_SYS_STATUS_LOGGING
SENSORS_HEALTHY = (mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                   | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                   | mavlink.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE | mavlink.MAV_SYS_STATUS_SENSOR_GPS
                   | mavlink.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
                   | mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL | mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
                   | mavlink.MAV_SYS_STATUS_AHRS | mavlink.MAV_SYS_STATUS_LOGGING
                   | mavlink.MAV_SYS_STATUS_SENSOR_BATTERY)
LOAD_PERMILLE = 137  # PX4 SITL's CPU load as measured: 13.7 %
BATTERY_CURRENT_CA = -100  # PX4 SITL's battery does not measure current: -1 A
# ESTIMATOR_STATUS.flags as PX4 SITL's EKF2 on the ground (1023)
ESTIMATOR_FLAGS = (mavlink.ESTIMATOR_ATTITUDE | mavlink.ESTIMATOR_VELOCITY_HORIZ | mavlink.ESTIMATOR_VELOCITY_VERT
                   | mavlink.ESTIMATOR_POS_HORIZ_REL | mavlink.ESTIMATOR_POS_HORIZ_ABS
                   | mavlink.ESTIMATOR_POS_VERT_ABS | mavlink.ESTIMATOR_POS_VERT_AGL
                   | mavlink.ESTIMATOR_CONST_POS_MODE | mavlink.ESTIMATOR_PRED_POS_HORIZ_REL
                   | mavlink.ESTIMATOR_PRED_POS_HORIZ_ABS)
GPS_SATELLITES, GPS_EPH, GPS_EPV = 10, 70, 110  # PX4 SITL's simulated GPS
GPS_H_ACC_MM, GPS_V_ACC_MM, GPS_VEL_ACC_MM_S = 500, 800, 200
RANGEFINDER_MIN_CM, RANGEFINDER_MAX_CM = 10, 4000
PWM_DISARMED, PWM_MIN, PWM_MAX = 1000, 1000, 2000
MOTORS = 4
RC_CHANNEL_COUNT, RC_STICKS_US, RC_SWITCH_LOW_US, RC_UNUSED = 8, [1500] * 4, 1000, 0xFFFF
RC_RSSI = 254  # full signal (255 would be "unknown")
# PX4 SITL (SIH) as recorded (bench/data/px4-hover-replay.json.xz): HIGHRES_IMU.temperature 15.0 deg C
# throughout, SCALED_PRESSURE.temperature the ISA's at the barometer's altitude (1181 cdeg at 489 m)
IMU_TEMPERATURE_C = 15.0
# HIGHRES_IMU.fields_updated as PX4 SITL (SIH) sets it: accelerometer and gyro fresh in every message,
# the magnetometer (0x1C0) in 14.15 a second and the barometer (abs_pressure, pressure_alt, temperature:
# 0x1A00) in 9.88, never diff_pressure: 887 of 1553 messages 0x3F, 356 0x1FF, 222 0x1A3F and 88 0x1BFF in
# the recorded 31.37 s hover (bench/data/px4-hover-replay.json.xz, from reference/conversations/
# takeoff-mavros-px4). Between its samples a sensor's fields hold their last value, as PX4 sends them.
HIGHRES_ACCEL_GYRO, HIGHRES_MAG = dialect.HIGHRES_IMU_UPDATED_ACCEL_GYRO, dialect.HIGHRES_IMU_UPDATED_MAG
HIGHRES_BARO = (dialect.HIGHRES_IMU_UPDATED_ABS_PRESSURE | dialect.HIGHRES_IMU_UPDATED_PRESSURE_ALT
                | dialect.HIGHRES_IMU_UPDATED_TEMPERATURE)
MAG_RATE_HZ, BARO_RATE_HZ = 14.15, 9.88
# ODOMETRY covariances: upper triangles of 6x6 matrices, row-major; only the diagonal is known
_DIAGONAL = (0, 6, 11, 15, 18, 20)
POSE_COVARIANCE = [0.0] * 21
VELOCITY_COVARIANCE = [0.0] * 21
for _i, _var in zip(_DIAGONAL, (0.01, 0.01, 0.02, 1e-4, 1e-4, 1e-3)):
    POSE_COVARIANCE[_i] = _var
for _i, _var in zip(_DIAGONAL, (0.01, 0.01, 0.01, 1e-4, 1e-4, 1e-4)):
    VELOCITY_COVARIANCE[_i] = _var
UNIX_2019_S = 1546300800  # OPEN_DRONE_ID_SYSTEM.timestamp counts from 2019-01-01 00:00 UTC
UINT16_UNKNOWN, INT16_UNKNOWN = 0xFFFF, 0x7FFF
NAN = float('nan')


class Streams:
    """The intervals of one link: `rates_hz` are its defaults."""

    def __init__(self, now_s, rates_hz=ONBOARD_RATES_HZ):
        self.defaults_s = {name: 1.0 / hz for name, hz in rates_hz.items()}
        self.names_by_id = NAMES_BY_ID
        self.interval_s = dict(self.defaults_s)  # as set (what MESSAGE_INTERVAL reports)
        self.period_s = {name: self._period(name, s) for name, s in self.interval_s.items()}  # as sent
        self.next_s = {name: now_s for name in self.interval_s}

    @staticmethod
    def _period(name, interval_s):
        """How often a stream goes out at an interval: no faster than its data updates."""
        return max(interval_s, UPDATE_PERIOD_S.get(name, 0.0))

    def set_interval(self, msg_id, interval_us, now_s):
        """Apply SET_MESSAGE_INTERVAL; True when accepted."""
        name = NAMES_BY_ID.get(int(msg_id))
        if name is None or name in FIXED_RATE or name in ON_REQUEST:
            return False
        if interval_us == 0:
            interval = self.defaults_s.get(name)
        elif interval_us < 0:
            interval = None
        else:
            interval = interval_us * 1e-6
        if interval is None:
            self.interval_s.pop(name, None)
            self.period_s.pop(name, None)
        else:
            self.interval_s[name] = interval
            self.period_s[name] = self._period(name, interval)
            self.next_s[name] = now_s
        return True

    def interval_us(self, msg_id):
        """For MESSAGE_INTERVAL: -1 stopped, 0 unknown/not available, else microseconds."""
        name = NAMES_BY_ID.get(int(msg_id))
        if name is None or name in ON_REQUEST:
            return 0
        interval = self.interval_s.get(name)
        return -1 if interval is None else int(round(interval * 1e6))

    def due(self, now_s):
        """Names of the streams to send now; their next times move on."""
        out = []
        next_s = self.next_s
        for name, interval in self.period_s.items():
            if now_s >= next_s[name]:
                out.append(name)
                # keep the cadence, but never queue a burst after a stall
                next_s[name] = max(next_s[name] + interval, now_s + interval * 0.5)
        return out


def pressure_hpa(alt_amsl_m):
    """ISA static pressure at an altitude AMSL."""
    return 1013.25 * (1.0 - 2.25577e-5 * alt_amsl_m) ** 5.25588


def temperature_c(alt_amsl_m):
    """ISA temperature at an altitude AMSL (15 deg C at sea level, 6.5 K a kilometre colder)."""
    return 15.0 - 0.0065 * alt_amsl_m


def euler(q):
    """(roll, pitch, yaw) in rad of a (w, x, y, z) NED/FRD quaternion."""
    w, x, y, z = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def to_body(q, v):
    """Rotate a NED vector into the FRD body frame of attitude q (w, x, y, z)."""
    w, x, y, z = q
    return ((1 - 2 * (y * y + z * z)) * v[0] + 2 * (x * y + w * z) * v[1] + 2 * (x * z - w * y) * v[2],
            2 * (x * y - w * z) * v[0] + (1 - 2 * (x * x + z * z)) * v[1] + 2 * (y * z + w * x) * v[2],
            2 * (x * z + w * y) * v[0] + 2 * (y * z - w * x) * v[1] + (1 - 2 * (x * x + y * y)) * v[2])


def position_target_type_mask(position, velocity, acceleration, yaw, yaw_rate):
    """POSITION_TARGET_TYPEMASK ignore bits for the NaN (uncontrolled) fields."""
    mask = 0
    for values, bits in ((position, (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE,
                                     mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE,
                                     mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE)),
                         (velocity, (mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE,
                                     mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE,
                                     mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE)),
                         (acceleration, (mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE,
                                         mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE,
                                         mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)),
                         ((yaw,), (mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE,)),
                         ((yaw_rate,), (mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE,))):
        for value, bit in zip(values, bits):
            if value != value:
                mask |= bit
    return mask


def sensors_health(prearm_ok):
    """SYS_STATUS onboard_control_sensors_health: PREARM_CHECK only while the arming checks pass."""
    return SENSORS_HEALTHY | (mavlink.MAV_SYS_STATUS_PREARM_CHECK if prearm_ok else 0)


def battery_charge_state(remaining):
    """MAV_BATTERY_CHARGE_STATE for a charge 0..1 (PX4's BAT_LOW_THR 0.15, BAT_CRIT_THR 0.07, BAT_EMERGEN_THR 0.05)."""
    if remaining < 0.05:
        return mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY
    if remaining < 0.07:
        return mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL
    if remaining < 0.15:
        return mavlink.MAV_BATTERY_CHARGE_STATE_LOW
    return mavlink.MAV_BATTERY_CHARGE_STATE_OK


def servo_pwm(armed, thrust):
    """Motor PWM (us): the disarmed value, else the thrust (0..1) mapped onto PWM_MIN..PWM_MAX."""
    if not armed:
        return PWM_DISARMED
    return int(round(PWM_MIN + (PWM_MAX - PWM_MIN) * max(0.0, min(1.0, thrust))))


def _finite_or_zero(values):
    return [v if v == v else 0.0 for v in values]


def _next_sample_s(due_s, now_s, rate_hz):
    """When a sensor sampling at rate_hz, sampled now for its sample due at due_s, is due next: one period
    on from due_s (so the rate holds on a 50 Hz message), or from now after a pause (no burst to catch up)."""
    next_s = due_s + 1.0 / rate_hz
    return next_s if next_s > now_s else now_s + 1.0 / rate_hz


class TelemetryBuilder:
    """Builds the autopilot's messages with `mav` (a pymavlink codec) from a flight Status, as wire.Outgoing
    messages (pymavlink's message of the same arguments on demand)."""

    def __init__(self, mav, frame, params, boot_s=0.0):
        # the streams' messages are wire.Outgoing: framed by the links from their arguments, as pymavlink
        # would pack them, without a pymavlink message object each
        self.mav, self.frame, self.params = wire.Encoder(mav), frame, params
        self.boot_s = boot_s
        self.uid = UID_BASE + mav.srcSystem
        self.ping_seq = 0
        self._for = None   # the Status the cache below belongs to
        self._cache = {}
        self._mag = self._baro = None  # HIGHRES_IMU's held magnetometer and barometer fields
        self._mag_due_s = self._baro_due_s = boot_s  # when each sensor's next sample is due

    def time_boot_ms(self, now_s):
        return int((now_s - self.boot_s) * 1000) & 0xFFFFFFFF

    def time_usec(self, now_s):
        return int((now_s - self.boot_s) * 1e6)

    def build(self, name, status, now_s):
        """The message `name` for now, or None when there is nothing to say (no home yet)."""
        return getattr(self, '_' + name.lower())(status, now_s)

    # -- what several messages share, once per Status ---------------------------------------

    def _shared(self, st, key, compute):
        if st is not self._for:
            self._for, self._cache = st, {}
        value = self._cache.get(key)
        if value is None:
            value = self._cache[key] = compute(st)
        return value

    def _global(self, st):
        """(lat_e7, lon_e7, alt_amsl_mm) of the vehicle."""
        def compute(s):
            lat, lon, alt = self.frame.to_global(*s.position)
            return int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000))
        return self._shared(st, 'global', compute)

    def _euler(self, st):
        return self._shared(st, 'euler', lambda s: euler(s.attitude))

    def _course(self, st):
        """(ground speed m/s, course over ground in rad or None when not moving)."""
        def compute(s):
            speed = math.hypot(s.velocity[0], s.velocity[1])
            return speed, (math.atan2(s.velocity[1], s.velocity[0]) if speed > 0.1 else None)
        return self._shared(st, 'course', compute)

    # -- messages ------------------------------------------------------------------------------

    def _heartbeat(self, st, now_s):
        return self.mav.heartbeat_encode(self.params['MAV_TYPE'], mavlink.MAV_AUTOPILOT_PX4, st.base_mode,
                                         st.custom_mode, st.system_status, 3)

    def current_mode(self, st):
        """PX4's CURRENT_MODE: the standard mode of the mode flying (PX4's numbering, px4_modes), its
        custom_mode, and the mode the user chose (reference/px4-sitl-measured.md, section 3)."""
        return self.mav.current_mode_encode(px4_modes.standard_mode(st.custom_mode), st.custom_mode,
                                            st.intended_custom_mode)

    def _current_mode(self, st, now_s):
        return self.current_mode(st)

    def _sys_status(self, st, now_s):
        # the logger's bit leaves present and enabled while it is stopped; health keeps it (as PX4 SITL)
        logging = LOGGING_BITS if st.logging else 0
        return self.mav.sys_status_encode((SENSORS_PRESENT & ~LOGGING_BITS) | logging,
                                          (SENSORS_ENABLED & ~LOGGING_BITS) | logging, sensors_health(st.prearm_ok),
                                          LOAD_PERMILLE, int(round(st.battery_voltage * 1000)), BATTERY_CURRENT_CA,
                                          int(round(st.battery_remaining * 100)), 0, 0, 0, 0, 0, 0)

    def _battery_status(self, st, now_s):
        cell_mv = int(round(st.battery_voltage * 1000 / MOTORS))  # a 4S pack: one cell per motor arm
        return self.mav.battery_status_encode(
            0, mavlink.MAV_BATTERY_FUNCTION_ALL, mavlink.MAV_BATTERY_TYPE_LIPO, INT16_UNKNOWN,
            [cell_mv] * 4 + [UINT16_UNKNOWN] * 6, BATTERY_CURRENT_CA, -1, -1, int(round(st.battery_remaining * 100)),
            0, battery_charge_state(st.battery_remaining))

    def _attitude(self, st, now_s):
        roll, pitch, yaw = self._euler(st)
        return self.mav.attitude_encode(self.time_boot_ms(now_s), roll, pitch, yaw, *st.body_rates)

    def _attitude_quaternion(self, st, now_s):
        w, x, y, z = st.attitude
        return self.mav.attitude_quaternion_encode(self.time_boot_ms(now_s), w, x, y, z, *st.body_rates,
                                                   [0.0, 0.0, 0.0, 0.0])

    def _local_position_ned(self, st, now_s):
        return self.mav.local_position_ned_encode(self.time_boot_ms(now_s), *st.position, *st.velocity)

    def _odometry(self, st, now_s):
        # same clock and values as LOCAL_POSITION_NED and ATTITUDE_QUATERNION
        return self.mav.odometry_encode(
            self.time_usec(now_s), mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_FRD, *st.position,
            list(st.attitude), *to_body(st.attitude, st.velocity), *st.body_rates,
            POSE_COVARIANCE, VELOCITY_COVARIANCE, 0, mavlink.MAV_ESTIMATOR_TYPE_GPS_INS, 100)

    def _global_position_int(self, st, now_s):
        lat, lon, alt = self._global(st)
        heading = int(round(math.degrees(st.yaw) * 100.0)) % 36000
        return self.mav.global_position_int_encode(
            self.time_boot_ms(now_s), lat, lon, alt, int(round(st.height * 1000)),
            *(int(round(c * 100)) for c in st.velocity), heading)

    def _gps_raw_int(self, st, now_s):
        lat, lon, alt = self._global(st)
        speed, course = self._course(st)
        cog = UINT16_UNKNOWN if course is None else int(round(math.degrees(course) * 100.0)) % 36000
        return self.mav.gps_raw_int_encode(
            self.time_usec(now_s), mavlink.GPS_FIX_TYPE_3D_FIX, lat, lon, alt, GPS_EPH, GPS_EPV,
            int(round(speed * 100)), cog, GPS_SATELLITES, alt, GPS_H_ACC_MM, GPS_V_ACC_MM, GPS_VEL_ACC_MM_S, 0, 0)

    def _amsl(self, st):
        """Altitude AMSL (m) of the estimate: the local frame's origin is at the frame's altitude."""
        return self.frame.alt0 - st.position[2]

    def _altitude(self, st, now_s):
        # PX4's ALTITUDE: monotonic and amsl from the estimate, local = -z, relative to home;
        # flat ground at home's altitude: terrain is home's AMSL altitude, the clearance the height.
        # Every field is a number, as PX4 SITL's (never NaN).
        amsl = self._amsl(st)
        home_amsl = self.frame.alt0 - st.home[2]
        return self.mav.altitude_encode(self.time_usec(now_s), amsl, amsl, -st.position[2], st.height, home_amsl,
                                        max(st.height, 0.0))

    def _vfr_hud(self, st, now_s):
        speed, _ = self._course(st)
        heading = int(round(math.degrees(st.yaw))) % 360
        throttle = int(round(st.thrust * 100)) if st.armed else 0
        # no airspeed sensor and no wind: airspeed is the ground speed
        return self.mav.vfr_hud_encode(speed, speed, heading, throttle, self._amsl(st), -st.velocity[2])

    def _rc_channels(self, st, now_s):
        if not st.rc:  # PX4 sends RC_CHANNELS only while an RC input updates
            return None
        # the simulated transmitter: sticks centred (throttle too: PX4's position modes hold), switches low
        channels = RC_STICKS_US + [RC_SWITCH_LOW_US] * (RC_CHANNEL_COUNT - len(RC_STICKS_US))
        channels += [RC_UNUSED] * (18 - RC_CHANNEL_COUNT)
        return self.mav.rc_channels_encode(self.time_boot_ms(now_s), RC_CHANNEL_COUNT, *channels, RC_RSSI)

    def _extended_sys_state(self, st, now_s):
        return self.mav.extended_sys_state_encode(mavlink.MAV_VTOL_STATE_UNDEFINED, st.landed_state)

    def _home_position(self, st, now_s):
        if st.home_set_s is None:  # PX4 sets home once its estimator has a position (sim.flight.HOME_SET_S)
            return None
        # home is where the vehicle was armed (PX4 sets it again at arming), in both frames; time_usec is
        # the boot time it was set at, as PX4's (2448000 and then 3792000 in the recorded conversation)
        lat, lon, alt = self.frame.to_global(*st.home)
        return self.mav.home_position_encode(int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)),
                                             *st.home, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0,
                                             int(round(st.home_set_s * 1e6)))

    def _highres_imu(self, st, now_s):
        ax, ay, az = st.specific_force
        fresh = HIGHRES_ACCEL_GYRO
        if self._mag is None or now_s >= self._mag_due_s:
            c, s = math.cos(st.yaw), math.sin(st.yaw)
            mag_n, mag_d = 0.21, 0.43  # gauss, roughly central Europe
            self._mag = (c * mag_n, -s * mag_n, mag_d)
            self._mag_due_s = _next_sample_s(self._mag_due_s, now_s, MAG_RATE_HZ)
            fresh |= HIGHRES_MAG
        if self._baro is None or now_s >= self._baro_due_s:
            alt = self._amsl(st)
            self._baro = (pressure_hpa(alt), alt)
            self._baro_due_s = _next_sample_s(self._baro_due_s, now_s, BARO_RATE_HZ)
            fresh |= HIGHRES_BARO
        pressure, alt = self._baro
        return self.mav.highres_imu_encode(self.time_usec(now_s), ax, ay, az, *st.gyro, *self._mag,
                                           pressure, 0.0, alt, IMU_TEMPERATURE_C, fresh)

    def _scaled_pressure(self, st, now_s):
        alt = self._amsl(st)
        return self.mav.scaled_pressure_encode(self.time_boot_ms(now_s), pressure_hpa(alt), 0.0,
                                               int(round(temperature_c(alt) * 100)))

    def _distance_sensor(self, st, now_s):
        w, x, y, z = st.attitude
        cos_tilt = max(0.1, 1.0 - 2.0 * (x * x + y * y))  # a downward rangefinder sees the slant range
        distance_cm = int(round(st.height / cos_tilt * 100))
        distance_cm = max(RANGEFINDER_MIN_CM, min(RANGEFINDER_MAX_CM, distance_cm))
        return self.mav.distance_sensor_encode(self.time_boot_ms(now_s), RANGEFINDER_MIN_CM, RANGEFINDER_MAX_CM,
                                               distance_cm, mavlink.MAV_DISTANCE_SENSOR_LASER, 0,
                                               mavlink.MAV_SENSOR_ROTATION_PITCH_270, 1)

    def _position_target_local_ned(self, st, now_s):
        p, v, a = st.position_setpoint, st.velocity_setpoint, st.acceleration_setpoint
        mask = position_target_type_mask(p, v, a, st.yaw_setpoint, st.yaw_rate_setpoint)
        return self.mav.position_target_local_ned_encode(
            self.time_boot_ms(now_s), mavlink.MAV_FRAME_LOCAL_NED, mask, *_finite_or_zero(p), *_finite_or_zero(v),
            *_finite_or_zero(a), st.yaw_setpoint, st.yaw_rate_setpoint if st.yaw_rate_setpoint == st.yaw_rate_setpoint
            else 0.0)

    def _position_target_global_int(self, st, now_s):
        """The navigator's setpoint in MAV_FRAME_GLOBAL_INT, type_mask 0, as PX4 sends it while armed in an
        AUTO mode (its position where the setpoint leaves one open; unknown vectors NaN, as recorded)."""
        if not (st.armed and st.nav_mode.startswith('AUTO.')):
            return None
        p = tuple(sp if sp == sp else now for sp, now in zip(st.position_setpoint, st.position))
        lat, lon, alt = self.frame.to_global(*p)
        v, a = st.velocity_setpoint, st.acceleration_setpoint
        return self.mav.position_target_global_int_encode(
            self.time_boot_ms(now_s), mavlink.MAV_FRAME_GLOBAL_INT, 0, int(round(lat * 1e7)), int(round(lon * 1e7)),
            alt, *v, *_finite_or_zero(a), st.yaw_setpoint,
            st.yaw_rate_setpoint if st.yaw_rate_setpoint == st.yaw_rate_setpoint else 0.0)

    def _attitude_target(self, st, now_s):
        acc = st.acceleration_setpoint
        if acc[0] != acc[0]:  # not flying: level, at the current heading, no thrust
            q = quaternion_from_thrust((0.0, 0.0, 0.0), st.yaw_setpoint)
        else:
            q = quaternion_from_thrust(acc, st.yaw_setpoint)
        yaw_rate = st.yaw_rate_setpoint if st.yaw_rate_setpoint == st.yaw_rate_setpoint else st.yaw_rate
        return self.mav.attitude_target_encode(self.time_boot_ms(now_s), 0, list(q), 0.0, 0.0, yaw_rate, st.thrust)

    def _servo_output_raw(self, st, now_s):
        pwm = servo_pwm(st.armed, st.thrust)
        return self.mav.servo_output_raw_encode(self.time_usec(now_s) & 0xFFFFFFFF, 0, pwm, pwm, pwm, pwm,
                                                0, 0, 0, 0)

    def _estimator_status(self, st, now_s):
        return self.mav.estimator_status_encode(self.time_usec(now_s), ESTIMATOR_FLAGS, 0.05, 0.05, 0.05, 0.05,
                                                0.0, 0.0, GPS_H_ACC_MM / 1000.0, GPS_V_ACC_MM / 1000.0)

    def _vibration(self, st, now_s):
        return self.mav.vibration_encode(self.time_usec(now_s), 0.01, 0.01, 0.01, 0, 0, 0)

    def _system_time(self, st, now_s):
        return self.mav.system_time_encode(int(time.time() * 1e6), self.time_boot_ms(now_s))

    def _timesync(self, st, now_s):
        """A TIMESYNC request (tc1 0) on the boot clock, as PX4 sends them at 10 Hz."""
        return self.mav.timesync_encode(0, int((now_s - self.boot_s) * 1e9))

    def _time_estimate_to_target(self, st, now_s):
        """PX4's stream: the RTL estimate with its margin (RTL_TIME_FACTOR x t + RTL_TIME_MARGIN, s),
        0 while PX4 has no estimate (landed, no home yet); PX4 estimates nothing else (-1)."""
        p = self.params
        t = None
        if st.ready:
            t = rtl_time_estimate(p, st.position, st.home, st.landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND,
                                  st.rtl)
        safe = 0 if t is None else int(t * p['RTL_TIME_FACTOR'] + p['RTL_TIME_MARGIN'])
        return self.mav.time_estimate_to_target_encode(safe, -1, -1, -1, -1)

    def link_node_status(self, counters, now_s):
        """A link's LINK_NODE_STATUS from its LinkCounters, as PX4 fills it: timestamp in us since
        boot (the XML says ms; PX4 sends hrt_absolute_time()), buffers 0 (PX4: "TODO"), rates in
        bytes/s over the last whole second, parse errors, messages sent, received and lost."""
        c = counters.update(now_s)
        return self.mav.link_node_status_encode(
            self.time_usec(now_s), 0, 0, int(counters.tx_rate), int(counters.rx_rate), c['bad_frames'] & 0xFFFF,
            0, 0, c['messages_sent'] & 0xFFFFFFFF, (c['received'] + c['other_system']) & 0xFFFFFFFF,
            counters.lost & 0xFFFFFFFF)

    def _ping(self, st, now_s):
        self.ping_seq = (self.ping_seq + 1) & 0xFFFFFFFF
        return self.mav.ping_encode(self.time_usec(now_s), self.ping_seq, 0, 0)

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
        f = self.frame
        return self.mav.open_drone_id_system_encode(
            0, 0, [0] * 20, mavlink.MAV_ODID_OPERATOR_LOCATION_TYPE_TAKEOFF,
            mavlink.MAV_ODID_CLASSIFICATION_TYPE_UNDECLARED, int(round(f.lat0 * 1e7)), int(round(f.lon0 * 1e7)),
            1, 0, -1000.0, -1000.0, mavlink.MAV_ODID_CATEGORY_EU_UNDECLARED, mavlink.MAV_ODID_CLASS_EU_UNDECLARED,
            f.alt0, int(time.time()) - UNIX_2019_S)

    def _mission_current(self, st, now_s):
        return self.mav.mission_current_encode(st.mission_seq, st.mission_count)

    def _gps_global_origin(self, st, now_s):
        """The estimator's origin (the local frame's), as PX4's GPS_GLOBAL_ORIGIN stream fills it:
        degE7, mm AMSL, time_usec the boot time the origin was set; None before it is."""
        if now_s < ORIGIN_SET_S:
            return None
        return self.mav.gps_global_origin_encode(int(round(self.frame.lat0 * 1e7)), int(round(self.frame.lon0 * 1e7)),
                                                 int(round(self.frame.alt0 * 1000)), int(ORIGIN_SET_S * 1e6))

    def _autopilot_version(self, st, now_s):
        return self.mav.autopilot_version_encode(CAPABILITIES, PX4_VERSION, PX4_VERSION, PX4_OS_SW_VERSION,
                                                 PX4_BOARD_VERSION, PX4_CUSTOM_VERSION, PX4_CUSTOM_VERSION, [0] * 8,
                                                 0, 0, self.uid)

    def _protocol_version(self, st, now_s):
        """As PX4 SITL answers (reference/px4-sitl-measured.md, "Turn 3 recordings", section 4):
        MAVLink 2 (200), min 100, max 203, no spec hash (all zero), and the library hash of the
        mavlink submodule PX4 was built with (its commit as a little-endian uint64, wire order)."""
        return self.mav.protocol_version_encode(200, 100, 203, [0] * 8, list(MAVLINK_LIBRARY_HASH))

    def statustext(self, severity, text, text_id):
        """A text as PX4's STATUSTEXT stream sends it: the first STATUSTEXT_MAX_CHARS of it (PX4's log
        queue's char[127]) in chunks of 50 bytes, chunk_seq 0, 1, ..., each with the text's `text_id`;
        nothing for an empty text, as PX4."""
        data = text.encode('ascii', 'replace')[:STATUSTEXT_MAX_CHARS]
        chunk = STATUSTEXT_CHUNK_BYTES
        return [self.mav.statustext_encode(severity, data[i:i + chunk], text_id, seq)
                for seq, i in enumerate(range(0, len(data), chunk))]


class LinkCounters:
    """A link's byte rates as PX4's mavlink module keeps them (telemetry_status tx/rx_rate_avg): the
    bytes of a window of (about) a second over its length, a new window each time. PX4's main loop
    closes a window every second whoever reads it; here the window closes when the rates are read
    at least WINDOW_S after it opened (a 1 Hz LINK_NODE_STATUS reads them once a window).

    `lost` counts what the senders' sequence numbers say was lost, per (system, component), as PX4's
    MavlinkReceiver::update_rx_stats does (`on_frame` sees every valid frame the link receives):
    a sequence number behind the expected one counts 255 - expected + seq, so a sender that always
    sends seq 0 costs 254 a message (reference/px4-sitl-measured.md, "Turn 3 recordings", section 4)."""

    WINDOW_S = 0.999  # a second, less the float error of a 1 Hz stream's slot times

    def __init__(self, stats, now_s):
        self.stats = stats  # the link's Counter (MavlinkLink.stats)
        self.tx_rate = self.rx_rate = 0.0
        self._since_s, self._tx, self._rx = now_s, 0, 0
        self.lost = 0
        self._last_seq = {}  # (system, component) -> the last sequence number

    def on_frame(self, frame):
        """A valid MAVLink 1 or 2 frame the link received (MavlinkLink.on_frames)."""
        if frame[0] == 0xFD:
            seq, source = frame[4], (frame[5], frame[6])
        else:
            seq, source = frame[2], (frame[3], frame[4])
        last = self._last_seq.get(source)
        if last is not None:
            expected = (last + 1) & 0xFF
            if seq > expected:
                self.lost += seq - expected
            elif seq < expected:
                self.lost += 255 - expected + seq
        self._last_seq[source] = seq

    def update(self, now_s):
        """The link's counters, the rates brought up to date first."""
        stats, dt = self.stats, now_s - self._since_s
        if dt >= self.WINDOW_S:
            tx, rx = stats['bytes_sent'], stats['bytes_received']
            self.tx_rate, self.rx_rate = (tx - self._tx) / dt, (rx - self._rx) / dt
            self._since_s, self._tx, self._rx = now_s, tx, rx
        return stats


class TimesyncAnswer(mavlink.MAVLink_timesync_message):
    """PX4's answer to a TIMESYNC request: tc1 and ts1 and MAVLink's extension fields target_system and
    target_component set to the requester (mavlink_timesync.cpp; recorded: PX4's answers to mavros carry
    1/240, reference/conversations). The dialect's TIMESYNC (pymavlink 2.4.49's) has no extensions, so the
    two bytes are appended to its payload here; a reader without them drops them, as MAVLink 2 allows."""

    def __init__(self, tc1, ts1, target_system, target_component):
        super().__init__(tc1, ts1)
        self.target_system, self.target_component = target_system, target_component

    def pack(self, mav, force_mavlink1=False):
        payload = self.unpacker.pack(self.tc1, self.ts1) + struct.pack('<BB', self.target_system,
                                                                         self.target_component)
        return self._pack(mav, self.crc_extra, payload, force_mavlink1=force_mavlink1)
