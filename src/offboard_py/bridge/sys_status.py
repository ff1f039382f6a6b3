"""mavros sys_status: ~state (latched), ~extended_state, ~sys_status, ~set_mode, our HEARTBEAT, the connection.

- Every HEARTBEAT from the target system and component restarts the `conn/timeout` timer
  and publishes State (connected, armed/guided/manual_input from base_mode, the PX4 mode
  string, system_status). On expiry, one "disconnected" State. One at start too.
- ~set_mode reads custom_mode as mavros's cmode_from_str: nothing before the FCU's first
  HEARTBEAT names a PX4 autopilot ("MODE: Unsupported FCU", mode_sent=false); upper-cased, an
  exact mode name, else the number std::stoi reads from it; neither: mode_sent=false; a number
  outside int: the call fails, as mavros's uncaught exception makes it fail. Known: one SET_MODE
  is sent, no acknowledgement is awaited.
- Our own HEARTBEAT at conn/heartbeat_rate, as mavros's: ONBOARD_CONTROLLER (conn/heartbeat_mav_type), autopilot INVALID,
  base_mode MAV_MODE_MANUAL_ARMED (192), system_status ACTIVE (reference/px4-sitl-measured.md,
  "Recorded conversations": real mavros's HEARTBEAT carries base_mode 192).
- ~sys_status (mavros_msgs/SysStatus): each SYS_STATUS as it is (not a gimbal's), stamped on arrival.
- AUTOPILOT_VERSION is asked for 1 s after the connection, as mavros's version timer does
  (COMMAND_LONG 520 recorded 1.0 s after PX4's first HEARTBEAT).
"""

import rospy
from mavros_msgs.msg import EstimatorStatus, ExtendedState, State, SysStatus as SysStatusMsg
from mavros_msgs.srv import SetMode, SetModeResponse

from offboard_py import px4_modes
from offboard_py.bridge import diagnostics, filters
from offboard_py.dialect import mavlink


ESTIMATOR_FLAGS = (('attitude_status_flag', mavlink.ESTIMATOR_ATTITUDE),
                   ('velocity_horiz_status_flag', mavlink.ESTIMATOR_VELOCITY_HORIZ),
                   ('velocity_vert_status_flag', mavlink.ESTIMATOR_VELOCITY_VERT),
                   ('pos_horiz_rel_status_flag', mavlink.ESTIMATOR_POS_HORIZ_REL),
                   ('pos_horiz_abs_status_flag', mavlink.ESTIMATOR_POS_HORIZ_ABS),
                   ('pos_vert_abs_status_flag', mavlink.ESTIMATOR_POS_VERT_ABS),
                   ('pos_vert_agl_status_flag', mavlink.ESTIMATOR_POS_VERT_AGL),
                   ('const_pos_mode_status_flag', mavlink.ESTIMATOR_CONST_POS_MODE),
                   ('pred_pos_horiz_rel_status_flag', mavlink.ESTIMATOR_PRED_POS_HORIZ_REL),
                   ('pred_pos_horiz_abs_status_flag', mavlink.ESTIMATOR_PRED_POS_HORIZ_ABS),
                   ('gps_glitch_status_flag', mavlink.ESTIMATOR_GPS_GLITCH),
                   ('accel_error_status_flag', mavlink.ESTIMATOR_ACCEL_ERROR))
VERSION_REQUEST_AFTER_CONNECT_S = 1.0  # mavros's autopilot_version_timer period, started on connection
# how many values mavros 1.21's string tables hold (enum_to_string.cpp): a value past them is shown as its number
MAVROS_ENUM_STRINGS = {'MAV_TYPE': 43, 'MAV_AUTOPILOT': 21, 'MAV_STATE': 9}


def enum_string(enum, value):
    """mavros's utils::to_string for MAV_TYPE, MAV_AUTOPILOT and MAV_STATE: the description up to its
    first ',', '-', '/' or '.' ("Quadrotor", "PX4 Autopilot"), for MAV_STATE the name's tail in title
    case ("Standby"), the number past mavros's table."""
    entry = mavlink.enums[enum].get(value)
    if entry is None or value >= MAVROS_ENUM_STRINGS[enum]:
        return str(value)
    if enum == 'MAV_STATE':
        return entry.name[len(enum) + 1:].title()
    text = entry.description
    for i, char in enumerate(text):
        if char in ',-/.':
            return text[:i].strip()
    return text.strip()


# SYS_STATUS's sensor bits as mavros 1.21 names them in its "System" status (the MAVLink descriptions, generated
# up to PROPULSION): (bit, name), in the bits' order
SENSOR_NAMES = tuple((bit, entry.description.split(' ', 1)[1].strip() if entry.description.startswith('0x')
                      else entry.description.strip())
                     for bit, entry in sorted(mavlink.enums['MAV_SYS_STATUS_SENSOR'].items())
                     if bit <= mavlink.MAV_SYS_STATUS_SENSOR_PROPULSION)


def system_status(st):
    """mavros's SystemStatusDiag for a SYS_STATUS (None: none yet, all zero as mavros starts)."""
    present, enabled, health = ((st.onboard_control_sensors_present, st.onboard_control_sensors_enabled,
                                 st.onboard_control_sensors_health) if st else (0, 0, 0))
    level, message = (2, 'Sensor health') if health & enabled != enabled else (0, 'Normal')
    values = [('Sensor present', '0x%08X' % present), ('Sensor enabled', '0x%08X' % enabled),
              ('Sensor health', '0x%08X' % health)]
    values += [(name, 'Ok' if health & bit else 'Fail') for bit, name in SENSOR_NAMES if enabled & bit]
    fields = (st.load, st.drop_rate_comm, st.errors_comm, st.errors_count1, st.errors_count2, st.errors_count3,
              st.errors_count4) if st else (0,) * 7
    values += [('CPU Load (%)', '%.1f' % (fields[0] / 10.0)), ('Drop rate (%)', '%.1f' % (fields[1] / 10.0)),
               ('Errors comm', '%d' % fields[2])]
    values += [('Errors count #%d' % i, '%d' % count) for i, count in enumerate(fields[3:], 1)]
    return level, message, values


C_SPACE = ' \t\n\v\f\r'
INT_MIN, INT_MAX = -2 ** 31, 2 ** 31 - 1


def c_stoi(text):
    """std::stoi(text, nullptr, 0), as mavros reads a mode number: leading white space, a sign, then
    hex after 0x, octal after 0, else decimal, as far as the digits go ('6ABC' is 6, '010' is 8).
    None where no number starts the text (stoi's invalid_argument); OverflowError outside int
    (its out_of_range)."""
    rest = text.lstrip(C_SPACE)
    sign = -1 if rest[:1] == '-' else 1
    if rest[:1] in ('+', '-'):
        rest = rest[1:]
    if rest[:2] in ('0x', '0X') and rest[2:3] and rest[2] in '0123456789abcdefABCDEF':
        base, rest = 16, rest[2:]
    else:
        base = 8 if rest[:1] == '0' else 10
    allowed = '0123456789abcdefABCDEF'[:base + (6 if base == 16 else 0)]
    end = 0
    while end < len(rest) and rest[end] in allowed:
        end += 1
    if end == 0:
        return None
    value = sign * int(rest[:end], base)
    if not INT_MIN <= value <= INT_MAX:
        raise OverflowError('%s is outside a 32-bit int' % rest[:end])
    return value


def custom_mode_from_string(text):
    """The custom_mode for a SetMode request string as mavros's cmode_from_str finds it in PX4's
    table: upper-cased, an exact name, else the number stoi reads, as uint32 ('-1' is 0xFFFFFFFF).
    None when neither; OverflowError for a number outside int, which mavros does not catch."""
    name = ''.join(c.upper() if 'a' <= c <= 'z' else c for c in text)  # C's toupper: ASCII only
    if name in px4_modes.MODES:
        return px4_modes.encode(name)
    value = c_stoi(name)
    return None if value is None else value & 0xFFFFFFFF



def mav_type_from_name(name):
    """mavros's utils::mav_type_from_str: MAV_TYPE_<name> (GCS, ONBOARD_CONTROLLER, ...), GENERIC with an
    error for an unknown name, as mavros."""
    value = getattr(mavlink, 'MAV_TYPE_' + name, None) if name.isupper() else None
    if not isinstance(value, int) or name.endswith('ENUM_END'):
        rospy.logerr('TYPE: Unknown MAV_TYPE: %s', name)
        return mavlink.MAV_TYPE_GENERIC
    return value

class SysStatus:
    def __init__(self, bridge):
        self.bridge = bridge
        self.timeout_s = bridge.cfg['conn/timeout']
        self.last_heartbeat_s = None
        self.base_mode = 0
        # what mavros's HeartbeatStatus shows before a heartbeat: GENERIC, GENERIC, UNINIT, no mode
        self.last_heartbeat = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GENERIC, mavlink.MAV_AUTOPILOT_GENERIC,
                                                                0, 0, mavlink.MAV_STATE_UNINIT, 0)
        self.last_mode = ''
        self.heartbeat_events = diagnostics.EventWindow(bridge.monotonic_s, min_hz=0.2, max_hz=100.0)
        bridge.diagnostic('Heartbeat', self._heartbeat_status)
        self.last_sys_status = None  # for the System status
        self.sys_status_pub = bridge.publisher('~sys_status', SysStatusMsg)
        bridge.on('SYS_STATUS', self._on_sys_status)  # decoded once for this and the battery plugin
        if not bridge.cfg['sys/disable_diag']:
            bridge.diagnostic('System', self._system_status)
        self.state_pub = bridge.publisher('~state', State, latch=True)
        self.extended_pub = bridge.publisher('~extended_state', ExtendedState)
        self.estimator_pub = bridge.publisher('~estimator_status', EstimatorStatus)
        bridge.on('ESTIMATOR_STATUS', self._on_estimator_status)
        self.set_mode_srv = bridge.service('~set_mode', SetMode, self._set_mode)
        bridge.on('HEARTBEAT', self._on_heartbeat, filters.COMPONENT)
        bridge.on('EXTENDED_SYS_STATE', self._on_extended_state)
        self.heartbeat_type = mav_type_from_name(bridge.cfg['conn/heartbeat_mav_type'])
        rate = bridge.cfg['conn/heartbeat_rate']
        if rate > 0:
            bridge.every(1.0 / rate, self._send_heartbeat)
        bridge.every(0.1, self._check_timeout)
        bridge.after_connect(VERSION_REQUEST_AFTER_CONNECT_S, self._request_version)
        self._publish_disconnected()

    def armed(self):
        return bool(self.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def _publish_disconnected(self):
        msg = State()
        msg.header.stamp = self.bridge.now()
        self.state_pub.publish(msg)

    def _on_heartbeat(self, hb):
        b = self.bridge
        self.last_heartbeat_s = b.monotonic_s()
        self.last_heartbeat = hb
        self.heartbeat_events.tick()
        self.base_mode = hb.base_mode
        msg = State()
        msg.header.stamp = b.now()
        msg.connected = True
        msg.armed = bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        msg.guided = bool(hb.base_mode & mavlink.MAV_MODE_FLAG_GUIDED_ENABLED)
        msg.manual_input = bool(hb.base_mode & mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)
        msg.mode = self.last_mode = px4_modes.mode_string(hb.base_mode, hb.custom_mode)
        msg.system_status = hb.system_status
        if not b.connected:
            rospy.loginfo('CON: Got HEARTBEAT, connected. FCU: PX4 Autopilot')
        b.set_connected(True)
        self.state_pub.publish(msg)

    def _heartbeat_status(self):
        """mavros's HeartbeatStatus: the target's heartbeats over the last ten periods (0.2-100 Hz)."""
        level, message, frequency = self.heartbeat_events.run()
        hb = self.last_heartbeat
        return level, message, [('Heartbeats since startup', self.heartbeat_events.count),
                                ('Frequency (Hz)', '%f' % frequency),
                                ('Vehicle type', enum_string('MAV_TYPE', hb.type)),
                                ('Autopilot type', enum_string('MAV_AUTOPILOT', hb.autopilot)),
                                ('Mode', self.last_mode),
                                ('System status', enum_string('MAV_STATE', hb.system_status))]

    def _on_sys_status(self, st):
        if st.get_srcComponent() == mavlink.MAV_COMP_ID_GIMBAL:  # mavros skips a gimbal's
            return
        self.last_sys_status = st
        if self.sys_status_pub.get_num_connections():
            msg = SysStatusMsg(sensors_present=st.onboard_control_sensors_present,
                               sensors_enabled=st.onboard_control_sensors_enabled,
                               sensors_health=st.onboard_control_sensors_health, load=st.load,
                               voltage_battery=st.voltage_battery, current_battery=st.current_battery,
                               battery_remaining=st.battery_remaining, drop_rate_comm=st.drop_rate_comm,
                               errors_comm=st.errors_comm, errors_count1=st.errors_count1,
                               errors_count2=st.errors_count2, errors_count3=st.errors_count3,
                               errors_count4=st.errors_count4)
            msg.header.stamp = self.bridge.now()
            self.sys_status_pub.publish(msg)

    def _system_status(self):
        return system_status(self.last_sys_status)

    def _check_timeout(self, now_s):
        if self.bridge.connected and now_s - self.last_heartbeat_s > self.timeout_s:
            rospy.logwarn('CON: Lost connection, HEARTBEAT timed out.')
            self.base_mode = 0
            self.bridge.set_connected(False)
            self._publish_disconnected()

    def _on_extended_state(self, ext):
        if not self.extended_pub.get_num_connections():
            return
        msg = ExtendedState()
        msg.header.stamp = self.bridge.now()
        msg.vtol_state, msg.landed_state = ext.vtol_state, ext.landed_state
        self.extended_pub.publish(msg)

    def _on_estimator_status(self, status):
        """~estimator_status: one bool per ESTIMATOR_STATUS_FLAGS bit, as mavros."""
        if not self.estimator_pub.get_num_connections():
            return
        msg = EstimatorStatus()
        msg.header.stamp = self.bridge.now()
        for field, flag in ESTIMATOR_FLAGS:
            setattr(msg, field, bool(status.flags & flag))
        self.estimator_pub.publish(msg)

    def _request_version(self):
        b = self.bridge
        if b.connected:
            b.send(b.mav.command_long_encode(b.target_system, b.target_component,
                                             mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 0, 1, 0, 0, 0, 0, 0, 0))

    def _send_heartbeat(self, _now_s):
        b = self.bridge
        b.send(b.mav.heartbeat_encode(self.heartbeat_type, mavlink.MAV_AUTOPILOT_INVALID,
                                      mavlink.MAV_MODE_MANUAL_ARMED, 0, mavlink.MAV_STATE_ACTIVE))

    def _set_mode(self, req):
        b = self.bridge
        base_mode = req.base_mode
        custom_mode = 0
        if req.custom_mode:
            if self.last_heartbeat.autopilot != mavlink.MAV_AUTOPILOT_PX4:
                # mavros picks its mode table by the autopilot of the last HEARTBEAT: none yet, no table
                rospy.logerr('MODE: Unsupported FCU')
                return SetModeResponse(mode_sent=False)
            try:
                custom_mode = custom_mode_from_string(req.custom_mode)
            except OverflowError as err:
                # mavros's std::stoi throws out of its service callback: the call fails
                rospy.logerr('MODE: mode number out of range: %s', err)
                raise rospy.ServiceException('set_mode: custom_mode %r: %s' % (req.custom_mode, err))
            if custom_mode is None:
                rospy.logerr('MODE: Unknown mode: %s', req.custom_mode)
                rospy.loginfo('MODE: Known modes are: %s', ' '.join(px4_modes.MODES))
                return SetModeResponse(mode_sent=False)
            base_mode |= mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            if self.armed():
                base_mode |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        b.send(b.mav.set_mode_encode(b.target_system, base_mode & 0xFF, custom_mode))
        return SetModeResponse(mode_sent=True)
