"""Which topics the simulated PX4's logger writes, how often, and what each holds of the flight.

`SUBSCRIPTIONS` are the topics of PX4's default set (src/modules/logger/logged_topics.cpp add_default_topics,
SDLOG_PROFILE 131 as PX4 SITL has it) that the simulator has values for, in that file's order, with their
intervals as PX4 SITL sets them: the SITL block (CONFIG_ARCH_BOARD_PX4_SITL) logs vehicle_attitude,
vehicle_global_position and vehicle_local_position at every update, and a topic added twice keeps the later
interval. The logger takes a sample of a topic when it was published and its interval has passed
(uORB SubscriptionInterval).

`FlightTopics` publishes them from the flight's Status, when PX4's module would: EKF2 its estimates at each of
its updates (here every cycle; global position once the global origin is set, src/modules/ekf2/EKF2.cpp), the
commander vehicle_status on a change and at least every 500 ms (Commander::run), the land detector on a
change and at least once a second (LandDetector::Run), home_position when home is set (commander/
HomePosition.cpp), the position controller and the flight task their setpoints while they fly one, the
battery every cycle. Vehicle commands and their acknowledgements are published by the receiver as they come
(`command_message`, `set_mode_message`, `vehicle_command_ack`: mavlink_receiver.cpp, the commander's answer at
the same time). A field the simulator does not model is 0 or
false, as in PX4's zero-initialised struct, or what PX4 sets when it has nothing (NaN, infinity).
Pure: time is passed in (seconds since boot; topics hold microseconds).
"""

from offboard_py import px4_modes
from offboard_py.dialect import MAV_CMD_INJECT_FAILURE, mavlink
from offboard_py.sim import uorb_topics as topics
from offboard_py.sim.mavlink.system_messages import ORIGIN_SET_S
from offboard_py.sim.mavlink.vehicle_commands import command_position

NAN, INF = float('nan'), float('inf')
VEHICLE_STATUS_PERIOD_S = 0.5  # Commander::run: publish at least every 500 ms
LAND_DETECTED_PERIOD_S = 1.0   # LandDetector::Run: at 1 Hz, and at once when the result changes
BATTERY_CURRENT_A = -1.0       # PX4 SITL's simulated battery measures no current (sim.mavlink.messages)
IDENTITY = (1.0, 0.0, 0.0, 0.0)

SUBSCRIPTIONS = (  # (topic, interval ms)
    (topics.HOME_POSITION, 0),
    (topics.TRAJECTORY_SETPOINT, 200),
    (topics.VEHICLE_ATTITUDE, 0),
    (topics.VEHICLE_COMMAND, 0),
    (topics.VEHICLE_COMMAND_ACK, 0),
    (topics.VEHICLE_GLOBAL_POSITION, 0),
    (topics.VEHICLE_LAND_DETECTED, 0),
    (topics.VEHICLE_LOCAL_POSITION, 0),
    (topics.VEHICLE_LOCAL_POSITION_SETPOINT, 100),
    (topics.VEHICLE_STATUS, 0),
    (topics.BATTERY_STATUS, 200),
)

# Commander's arm_disarm_reason_t for the reasons sim.commander gives
ARM_DISARM_REASONS = {
    'commanded': topics.ARM_DISARM_REASON_COMMAND_EXTERNAL,
    'external command': topics.ARM_DISARM_REASON_COMMAND_EXTERNAL,
    'landing': topics.ARM_DISARM_REASON_LANDING,
    'auto preflight disarming': topics.ARM_DISARM_REASON_PREFLIGHT_INACTION,
    'failsafe': topics.ARM_DISARM_REASON_FAILSAFE,
}
# Commands PX4's receiver answers itself and does not publish (MavlinkReceiver::handle_message_command_both)
ANSWERED_BY_RECEIVER = frozenset((
    mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION,
    mavlink.MAV_CMD_GET_HOME_POSITION, mavlink.MAV_CMD_REQUEST_FLIGHT_INFORMATION,
    mavlink.MAV_CMD_REQUEST_STORAGE_INFORMATION, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
    mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, mavlink.MAV_CMD_REQUEST_MESSAGE))


def us(seconds):
    return int(round(seconds * 1e6))


def vehicle_command(now_s, command, params, target, source, confirmation=0):
    """vehicle_command as PX4's receiver fills it: params (param1..param7, param5 and param6 as doubles, COMMAND_INT's
    x and y already in degrees), target (system, component), source (system, component); from_external."""
    p1, p2, p3, p4, p5, p6, p7 = params
    return {'timestamp': us(now_s), 'param1': p1, 'param2': p2, 'param3': p3, 'param4': p4, 'param5': p5,
            'param6': p6, 'param7': p7, 'command': command, 'target_system': target[0],
            'target_component': target[1], 'source_system': source[0], 'source_component': source[1],
            'confirmation': confirmation, 'from_external': True}


def command_message(msg, now_s, params):
    """The vehicle_command PX4's receiver publishes for a COMMAND_LONG or COMMAND_INT that passed its checks (its
    target, sentinels and frame: sim.mavlink.receiver), or None for one it answers itself: a request, a message
    interval, a failure injection with SYS_FAILURE_EN off, an autotune without the autotune module
    (MavlinkReceiver::handle_message_command_both). COMMAND_INT has no confirmation."""
    command = msg.command
    if command in ANSWERED_BY_RECEIVER or (command == MAV_CMD_INJECT_FAILURE and not params['SYS_FAILURE_EN']) \
            or (command == mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE and 'MC_AT_APPLY' not in params):
        return None
    confirmation = msg.confirmation if msg.get_type() == 'COMMAND_LONG' else 0
    return vehicle_command(now_s, command, (msg.param1, msg.param2, msg.param3, msg.param4) + command_position(msg),
                           (msg.target_system, msg.target_component), (msg.get_srcSystem(), msg.get_srcComponent()),
                           confirmation)


def set_mode_message(msg, now_s):
    """The DO_SET_MODE vehicle_command PX4's receiver publishes for a SET_MODE, whatever its target
    (MavlinkReceiver::handle_message_set_mode): base mode, main and sub mode; component all; confirmation 1."""
    main_mode, sub_mode = px4_modes.split(msg.custom_mode)
    return vehicle_command(now_s, mavlink.MAV_CMD_DO_SET_MODE, (msg.base_mode, main_mode, sub_mode, 0, 0, 0, 0),
                           (msg.target_system, mavlink.MAV_COMP_ID_ALL), (msg.get_srcSystem(), msg.get_srcComponent()),
                           confirmation=1)


def vehicle_command_ack(now_s, command, result, target):
    """vehicle_command_ack as MavlinkReceiver::acknowledge and the commander fill it, to target (system, component)."""
    return {'timestamp': us(now_s), 'command': command, 'result': result, 'target_system': target[0],
            'target_component': target[1]}


class FlightTopics:
    """The topics of `flight` (sim.flight.Flight) around `origin` (sim.geo.GeoOrigin) for system `system_id`:
    `track()` every cycle, then `publishers[topic name](now_s, status)`, the topic's values when it is
    published this cycle, or None."""

    def __init__(self, flight, origin, params, system_id):
        self.flight, self.origin, self.params, self.system_id = flight, origin, params, system_id
        self.armed, self.armed_us, self.takeoff_us = False, 0, 0
        self.arming_reason = self.disarming_reason = 0
        self.nav_state, self.nav_state_us = None, 0
        self.gcs_lost, self.gcs_lost_count = False, 0
        self.status_key, self.status_s = None, None
        self.land_key, self.land_s = None, None
        self.home_set_s, self.home_count, self.home_pending = None, 0, False
        self.publishers = {
            'vehicle_local_position': self._local_position, 'vehicle_global_position': self._global_position,
            'vehicle_attitude': self._attitude, 'vehicle_status': self._status,
            'vehicle_land_detected': self._land_detected, 'home_position': self._home,
            'trajectory_setpoint': self._trajectory_setpoint,
            'vehicle_local_position_setpoint': self._local_position_setpoint, 'battery_status': self._battery,
        }

    def on_arming(self, armed, reason):
        """An arming or disarming (sim.events.ArmingChanged's reason)."""
        code = ARM_DISARM_REASONS.get(reason, 0)
        if armed:
            self.arming_reason = code
        else:
            self.disarming_reason = code

    def restart(self):
        """A new log: the next sample of each topic is published at once, as a new log starts with each topic's
        latest sample."""
        self.status_key = self.land_key = None
        self.home_pending = self.home_set_s is not None

    def track(self, now_s, st):
        """What vehicle_status counts between its publications (arming and takeoff times, mode changes, GCS
        losses) and home's updates."""
        if st.home_set_s is not None and st.home_set_s != self.home_set_s:
            self.home_set_s, self.home_count, self.home_pending = st.home_set_s, self.home_count + 1, True
        if st.armed != self.armed:
            self.armed, self.armed_us, self.takeoff_us = st.armed, us(now_s) if st.armed else 0, 0
        if st.armed and not self.takeoff_us and st.landed_state != mavlink.MAV_LANDED_STATE_ON_GROUND:
            self.takeoff_us = us(now_s)
        nav_state = topics.NAVIGATION_STATE.get(st.nav_mode, 0)
        if nav_state != self.nav_state:
            self.nav_state, self.nav_state_us = nav_state, us(now_s)
        lost = self.flight.commander.data_link.lost
        if lost and not self.gcs_lost:
            self.gcs_lost_count = (self.gcs_lost_count + 1) & 0xFF
        self.gcs_lost = lost

    # -- EKF2 ----------------------------------------------------------------------------------

    def _origin_set(self, now_s):
        return now_s >= ORIGIN_SET_S

    def _local_position(self, now_s, st):
        t = us(now_s)
        x, y, z = st.position
        vx, vy, vz = st.velocity
        ax, ay, az = self.flight.vehicle.acceleration
        valid = self.flight.commander.position_valid
        values = {
            'timestamp': t, 'timestamp_sample': t, 'xy_valid': valid, 'z_valid': valid, 'v_xy_valid': valid,
            'v_z_valid': valid, 'x': x, 'y': y, 'z': z, 'vx': vx, 'vy': vy, 'vz': vz, 'z_deriv': vz,
            'ax': ax, 'ay': ay, 'az': az, 'heading': st.yaw, 'unaided_heading': NAN,
            'heading_good_for_control': True, 'dist_bottom': max(st.height, 0.0),
            'vxy_max': INF, 'vz_max': INF, 'hagl_min': INF, 'hagl_max_z': INF, 'hagl_max_xy': INF,
        }
        if self._origin_set(now_s):
            f = self.origin
            values.update(ref_timestamp=us(ORIGIN_SET_S), ref_lat=f.lat0, ref_lon=f.lon0, ref_alt=f.alt0,
                          xy_global=True, z_global=True)
        else:
            values.update(ref_lat=NAN, ref_lon=NAN, ref_alt=NAN)
        return values

    def _global_position(self, now_s, st):
        if not self._origin_set(now_s):
            return None
        t = us(now_s)
        lat, lon, alt = self.origin.to_global(*st.position)
        valid = self.flight.commander.position_valid
        return {'timestamp': t, 'timestamp_sample': t, 'lat': lat, 'lon': lon, 'alt': alt, 'alt_ellipsoid': alt,
                'lat_lon_valid': valid, 'alt_valid': valid, 'terrain_alt': NAN}

    def _attitude(self, now_s, st):
        t = us(now_s)
        return {'timestamp': t, 'timestamp_sample': t, 'q': st.attitude, 'delta_q_reset': IDENTITY}

    # -- commander, land detector ----------------------------------------------------------------

    def _status(self, now_s, st):
        key = (st.armed, self.nav_state, st.user_mode, st.failsafe, st.prearm_ok, self.gcs_lost)
        if key == self.status_key and now_s - self.status_s < VEHICLE_STATUS_PERIOD_S - 1e-9:
            return None
        self.status_key, self.status_s = key, now_s
        return {
            'timestamp': us(now_s), 'armed_time': self.armed_us, 'takeoff_time': self.takeoff_us,
            'arming_state': topics.ARMING_STATE_ARMED if st.armed else topics.ARMING_STATE_DISARMED,
            'latest_arming_reason': self.arming_reason, 'latest_disarming_reason': self.disarming_reason,
            'nav_state_timestamp': self.nav_state_us,
            'nav_state_user_intention': topics.NAVIGATION_STATE.get(st.user_mode, 0), 'nav_state': self.nav_state,
            'nav_state_display': self.nav_state, 'vehicle_type': topics.VEHICLE_TYPE_ROTARY_WING,
            'failsafe': st.failsafe, 'gcs_connection_lost': self.gcs_lost,
            'gcs_connection_lost_counter': self.gcs_lost_count, 'system_type': self.params['MAV_TYPE'],
            'system_id': self.system_id, 'component_id': mavlink.MAV_COMP_ID_AUTOPILOT1, 'safety_off': True,
            'power_input_valid': True, 'pre_flight_checks_pass': st.prearm_ok,
        }

    def _land_detected(self, now_s, st):
        v = self.flight.vehicle
        key = (v.landed, v.maybe_landed)
        if key == self.land_key and now_s - self.land_s < LAND_DETECTED_PERIOD_S - 1e-9:
            return None
        self.land_key, self.land_s = key, now_s
        # PX4's stages cascade (ground contact, then maybe landed, then landed): the simulator's word on the first
        # is the later two's
        return {'timestamp': us(now_s), 'ground_contact': v.landed or v.maybe_landed, 'maybe_landed': v.maybe_landed,
                'landed': v.landed, 'at_rest': v.landed}

    def _home(self, now_s, st):
        if not self.home_pending:
            return None
        self.home_pending = False
        lat, lon, alt = self.origin.to_global(*st.home)
        x, y, z = st.home
        return {'timestamp': us(self.home_set_s), 'lat': lat, 'lon': lon, 'alt': alt, 'x': x, 'y': y, 'z': z,
                'yaw': st.yaw, 'valid_alt': True, 'valid_hpos': True, 'valid_lpos': True,
                'update_count': self.home_count}

    # -- the position controller and the flight task ----------------------------------------------

    @staticmethod
    def _flying_setpoint(st):
        return any(v == v for vector in (st.position_setpoint, st.velocity_setpoint, st.acceleration_setpoint)
                   for v in vector)

    def _trajectory_setpoint(self, now_s, st):
        if not self._flying_setpoint(st):
            return None
        return {'timestamp': us(now_s), 'position': st.position_setpoint, 'velocity': st.velocity_setpoint,
                'acceleration': st.acceleration_setpoint, 'jerk': (NAN, NAN, NAN), 'yaw': st.yaw_setpoint,
                'yawspeed': st.yaw_rate_setpoint}

    def _local_position_setpoint(self, now_s, st):
        if not self._flying_setpoint(st):
            return None
        x, y, z = st.position_setpoint
        vx, vy, vz = st.velocity_setpoint
        return {'timestamp': us(now_s), 'x': x, 'y': y, 'z': z, 'vx': vx, 'vy': vy, 'vz': vz,
                'acceleration': st.acceleration_setpoint, 'thrust': tuple(self.flight.vehicle.thrust_setpoint),
                'yaw': st.yaw_setpoint, 'yawspeed': st.yaw_rate_setpoint}

    # -- the battery ------------------------------------------------------------------------------

    def _battery(self, now_s, st):
        cells = int(self.params['BAT1_N_CELLS'])
        cell_v = st.battery_voltage / cells if cells > 0 else NAN
        return {'timestamp': us(now_s), 'connected': True, 'voltage_v': st.battery_voltage,
                'current_a': BATTERY_CURRENT_A, 'current_average_a': BATTERY_CURRENT_A,
                'remaining': st.battery_remaining, 'scale': 1.0, 'time_remaining_s': NAN, 'temperature': NAN,
                'cell_count': cells, 'id': 1, 'warning': st.battery_warning,
                'voltage_cell_v': [cell_v] * min(cells, 14) + [NAN] * (14 - min(cells, 14))}
