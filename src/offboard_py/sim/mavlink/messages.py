"""The simulated PX4's messages, built from the flight's read-only Status as PX4's streams fill them
(src/modules/mavlink/streams/*.hpp: one class there per message, one method here).

`TelemetryBuilder.build(name, status, now_s)` makes each message from the flight's read-only
Status (sim.flight); it never sees the commander or the vehicle model. What several messages
share (global position, Euler angles) is computed once per Status, i.e. once per step.
The sensor messages are sim.mavlink.sensor_messages', the identity and system messages
sim.mavlink.system_messages'. LINK_NODE_STATUS is each link's own (`link_node_status`, from its
sim.mavlink.link_stats counters). Not sent: PX4's EVENT / CURRENT_EVENT_SEQUENCE (its event
interface, whose texts live in PX4's own metadata).
"""

import math

from offboard_py import frames, px4_modes, wire
from offboard_py.dialect import mavlink
from offboard_py.sim.flight_math import quaternion_from_thrust, to_body
from offboard_py.sim.mavlink.sensor_messages import UINT16_UNKNOWN, SensorMessages
from offboard_py.sim.mavlink.system_messages import UID_BASE, SystemMessages
from offboard_py.sim.rtl import rtl_time_estimate

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
PWM_DISARMED, PWM_MIN, PWM_MAX = 1000, 1000, 2000
MOTORS = 4
# ODOMETRY covariances: upper triangles of 6x6 matrices, row-major; only the diagonal is known
_DIAGONAL = (0, 6, 11, 15, 18, 20)
POSE_COVARIANCE = [0.0] * 21
VELOCITY_COVARIANCE = [0.0] * 21
for _i, _var in zip(_DIAGONAL, (0.01, 0.01, 0.02, 1e-4, 1e-4, 1e-3)):
    POSE_COVARIANCE[_i] = _var
for _i, _var in zip(_DIAGONAL, (0.01, 0.01, 0.01, 1e-4, 1e-4, 1e-4)):
    VELOCITY_COVARIANCE[_i] = _var
INT16_UNKNOWN = 0x7FFF


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


# Before the commander's first health report, SYS_STATUS.hpp fills a zeroed health_report: no component
# present or enabled, every one healthy (0x0321C83F in both recorded conversations from PX4's start)
SENSORS_HEALTHY_UNREPORTED = SENSORS_HEALTHY | mavlink.MAV_SYS_STATUS_SENSOR_RC_RECEIVER


def sensors_health(prearm_ok, unhealthy=0):
    """SYS_STATUS onboard_control_sensors_health: PREARM_CHECK only while the arming checks pass; the
    sensors a reported check marks unhealthy cleared (SYS_STATUS.hpp fillOutComponent)."""
    return (SENSORS_HEALTHY & ~unhealthy) | (mavlink.MAV_SYS_STATUS_PREARM_CHECK if prearm_ok else 0)


def sensors_words(st):
    """SYS_STATUS's (present, enabled, health) from the published health report, as SYS_STATUS.hpp fills them:
    nothing present before the first report; the GPS present (and so enabled) only once the estimator fuses
    it (estimatorCheck.cpp); the logger's bit leaves present and enabled while it is stopped, health keeps it."""
    if not st.health_published:
        return 0, 0, SENSORS_HEALTHY_UNREPORTED
    present = SENSORS_PRESENT
    if not st.gps_present:
        present &= ~mavlink.MAV_SYS_STATUS_SENSOR_GPS
    if not st.logging:
        present &= ~LOGGING_BITS
    enabled = present | (SENSORS_ENABLED & ~SENSORS_PRESENT)
    return present, enabled, sensors_health(st.prearm_ok, st.unhealthy_sensors)


def battery_charge_state(warning):
    """MAV_BATTERY_CHARGE_STATE for battery_status_s::WARNING_* 0-4 (NONE, LOW, CRITICAL, EMERGENCY, FAILED),
    as BATTERY_STATUS.hpp maps the battery's warning."""
    return (mavlink.MAV_BATTERY_CHARGE_STATE_OK, mavlink.MAV_BATTERY_CHARGE_STATE_LOW,
            mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL, mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY,
            mavlink.MAV_BATTERY_CHARGE_STATE_FAILED)[warning]


def servo_pwm(armed, thrust):
    """Motor PWM (us): the disarmed value, else the thrust (0..1) mapped onto PWM_MIN..PWM_MAX."""
    if not armed:
        return PWM_DISARMED
    return int(round(PWM_MIN + (PWM_MAX - PWM_MIN) * max(0.0, min(1.0, thrust))))


def _finite_or_zero(values):
    return [v if v == v else 0.0 for v in values]


class TelemetryBuilder(SensorMessages, SystemMessages):
    """Builds the autopilot's messages with `mav` (a pymavlink codec) from a flight Status, as wire.Outgoing
    messages (pymavlink's message of the same arguments on demand)."""

    def __init__(self, mav, origin, params, boot_s=0.0):
        # the streams' messages are wire.Outgoing: framed by the links from their arguments, as pymavlink
        # would pack them, without a pymavlink message object each
        self.mav, self.origin, self.params = wire.Encoder(mav), origin, params
        self.boot_s = boot_s
        self.uid = UID_BASE + mav.srcSystem
        self.ping_seq = 0
        self._for = None   # the Status the cache below belongs to
        self._cache = {}
        self._init_sensors(boot_s)

    def time_boot_ms(self, now_s):
        return int((now_s - self.boot_s) * 1000) & 0xFFFFFFFF

    def time_usec(self, now_s):
        return int((now_s - self.boot_s) * 1e6)

    def build(self, name, status, now_s):
        """The message `name` for now, or None when there is nothing to say (no home yet); `name` is one of
        BUILDERS (LINK_NODE_STATUS is each link's: link_node_status), anything else a ValueError."""
        try:
            builder = self.BUILDERS[name]
        except KeyError:
            raise ValueError('TelemetryBuilder has no builder for the message %r' % (name,)) from None
        return builder(self, status, now_s)

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
            lat, lon, alt = self.origin.to_global(*s.position)
            return int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000))
        return self._shared(st, 'global', compute)

    def _euler(self, st):
        return self._shared(st, 'euler', lambda s: frames.euler(frames.wxyz_to_xyzw(*s.attitude)))

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
        return self.mav.sys_status_encode(*sensors_words(st), LOAD_PERMILLE, int(round(st.battery_voltage * 1000)), BATTERY_CURRENT_CA,
                                          int(math.ceil(st.battery_remaining * 100)), 0, 0, 0, 0, 0, 0)

    def _battery_status(self, st, now_s):
        cell_mv = int(round(st.battery_voltage * 1000 / MOTORS))  # a 4S pack: one cell per motor arm
        return self.mav.battery_status_encode(
            0, mavlink.MAV_BATTERY_FUNCTION_ALL, mavlink.MAV_BATTERY_TYPE_LIPO, INT16_UNKNOWN,
            [cell_mv] * 4 + [UINT16_UNKNOWN] * 6, BATTERY_CURRENT_CA, -1, -1, int(round(st.battery_remaining * 100)),
            0, battery_charge_state(st.battery_warning))

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

    def _amsl(self, st):
        """Altitude AMSL (m) of the estimate: local NED's z is 0 at the origin's altitude."""
        return self.origin.alt0 - st.position[2]

    def _altitude(self, st, now_s):
        # PX4's ALTITUDE: monotonic and amsl from the estimate, local = -z, relative to home;
        # flat ground at home's altitude: terrain is home's AMSL altitude, the clearance the height.
        # Every field is a number, as PX4 SITL's (never NaN).
        amsl = self._amsl(st)
        home_amsl = self.origin.alt0 - st.home[2]
        return self.mav.altitude_encode(self.time_usec(now_s), amsl, amsl, -st.position[2], st.height, home_amsl,
                                        max(st.height, 0.0))

    def _vfr_hud(self, st, now_s):
        speed, _ = self._course(st)
        heading = int(round(math.degrees(st.yaw))) % 360
        throttle = int(round(st.thrust * 100)) if st.armed else 0
        # no airspeed sensor and no wind: airspeed is the ground speed
        return self.mav.vfr_hud_encode(speed, speed, heading, throttle, self._amsl(st), -st.velocity[2])

    def _extended_sys_state(self, st, now_s):
        return self.mav.extended_sys_state_encode(mavlink.MAV_VTOL_STATE_UNDEFINED, st.landed_state)

    def _home_position(self, st, now_s):
        if st.home_set_s is None:  # PX4 sets home once its estimator has a position (sim.flight.HOME_SET_S)
            return None
        # home is where the vehicle was armed (PX4 sets it again at arming), in both frames; time_usec is
        # the boot time it was set at, as PX4's (2448000 and then 3792000 in the recorded conversation)
        lat, lon, alt = self.origin.to_global(*st.home)
        return self.mav.home_position_encode(int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)),
                                             *st.home, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0,
                                             int(round(st.home_set_s * 1e6)))

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
        lat, lon, alt = self.origin.to_global(*p)
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

    def _mission_current(self, st, now_s):
        return self.mav.mission_current_encode(st.mission_seq, st.mission_count)

    # -- the builders by message name (build): builder(self, status, now_s) -------------------

    BUILDERS = {
        'HEARTBEAT': _heartbeat,
        'CURRENT_MODE': _current_mode,
        'SYS_STATUS': _sys_status,
        'BATTERY_STATUS': _battery_status,
        'ATTITUDE': _attitude,
        'ATTITUDE_QUATERNION': _attitude_quaternion,
        'LOCAL_POSITION_NED': _local_position_ned,
        'ODOMETRY': _odometry,
        'GLOBAL_POSITION_INT': _global_position_int,
        'ALTITUDE': _altitude,
        'VFR_HUD': _vfr_hud,
        'EXTENDED_SYS_STATE': _extended_sys_state,
        'HOME_POSITION': _home_position,
        'POSITION_TARGET_LOCAL_NED': _position_target_local_ned,
        'POSITION_TARGET_GLOBAL_INT': _position_target_global_int,
        'ATTITUDE_TARGET': _attitude_target,
        'SERVO_OUTPUT_RAW': _servo_output_raw,
        'TIMESYNC': _timesync,
        'TIME_ESTIMATE_TO_TARGET': _time_estimate_to_target,
        'PING': _ping,
        'MISSION_CURRENT': _mission_current,
        # sim.mavlink.sensor_messages
        'GPS_RAW_INT': SensorMessages._gps_raw_int,
        'HIGHRES_IMU': SensorMessages._highres_imu,
        'SCALED_PRESSURE': SensorMessages._scaled_pressure,
        'DISTANCE_SENSOR': SensorMessages._distance_sensor,
        'ESTIMATOR_STATUS': SensorMessages._estimator_status,
        'VIBRATION': SensorMessages._vibration,
        'RC_CHANNELS': SensorMessages._rc_channels,
        # sim.mavlink.system_messages
        'SYSTEM_TIME': SystemMessages._system_time,
        'OPEN_DRONE_ID_LOCATION': SystemMessages._open_drone_id_location,
        'OPEN_DRONE_ID_SYSTEM': SystemMessages._open_drone_id_system,
        'GPS_GLOBAL_ORIGIN': SystemMessages._gps_global_origin,
        'AUTOPILOT_VERSION': SystemMessages._autopilot_version,
        'PROTOCOL_VERSION': SystemMessages._protocol_version,
    }
