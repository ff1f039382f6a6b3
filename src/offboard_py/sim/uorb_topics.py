"""The uORB topics the simulated PX4's logger writes, as PX4 main 02e73e3b6f defines them and lays them out.

Each topic's fields are its message file's (msg/versioned/VehicleLocalPosition.msg and the others named below),
in the file's order, with PX4's types; `Topic` lays them out as PX4's uORB generator does for the C struct and
for the format the logger writes (Tools/msg/px_generate_uorb_topic_helper.py sizeof_field_type and
add_padding_bytes, used by Tools/msg/templates/uorb/msg.json.em): fields sorted by the size of their element
type, largest first, keeping the file's order among equals; the struct padded to 8 bytes with a last field
`uint8_t[N] _padding0`, which is in the format but not in a logged sample (the logger writes o_size_no_padding
bytes, src/modules/logger/logger.cpp). Only the builtin types are here: none of these topics nests another.

Also the constants of these messages that the simulator uses, under their PX4 names. What fills a topic from
the flight is sim.logged_topics'. Pure: no I/O.
"""

import collections
import operator
import struct

# bytes of each msg type, its C name in a ULog format, its struct code
_TYPES = {
    'uint64': (8, 'uint64_t', 'Q'), 'int64': (8, 'int64_t', 'q'), 'float64': (8, 'double', 'd'),
    'uint32': (4, 'uint32_t', 'I'), 'int32': (4, 'int32_t', 'i'), 'float32': (4, 'float', 'f'),
    'uint16': (2, 'uint16_t', 'H'), 'int16': (2, 'int16_t', 'h'),
    'uint8': (1, 'uint8_t', 'B'), 'int8': (1, 'int8_t', 'b'), 'bool': (1, 'bool', '?'), 'char': (1, 'char', 'c'),
}
STRUCT_ALIGN = 8  # add_padding_bytes pads every struct to a multiple of 8 bytes, its uint64 timestamp's size

Field = collections.namedtuple('Field', 'type name count')  # count: 1, or the array's length


def parse_fields(definition):
    """[Field] of a message's fields written one a line as in its .msg file ('float32[3] position')."""
    fields = []
    for line in definition.strip().splitlines():
        type_text, name = line.split()
        base, _, rest = type_text.partition('[')
        if base not in _TYPES:
            raise ValueError('%s: only builtin types are laid out here, not %r' % (name, base))
        fields.append(Field(base, name, int(rest[:-1]) if rest else 1))
    return fields


class Topic:
    """A uORB topic: its ULog format (`format`: 'name:type field;...'), the size of a logged sample (`size`,
    without the end padding) and `pack(values)`, a sample's bytes from {field name: value} (an array's value a
    sequence of its length); a field not given is 0 (False), as a zero-initialised struct of PX4's."""

    def __init__(self, name, definition):
        self.name = name
        self.fields = parse_fields(definition)
        laid_out = sorted(self.fields, key=lambda f: _TYPES[f.type][0], reverse=True)  # sorted() is stable
        self.size = sum(_TYPES[f.type][0] * f.count for f in laid_out)
        padding = -self.size % STRUCT_ALIGN
        text = ''.join('%s%s %s;' % (_TYPES[f.type][1], '[%d]' % f.count if f.count > 1 else '', f.name)
                       for f in laid_out)
        if padding:
            text += 'uint8_t[%d] _padding0;' % padding
        self.format = '%s:%s' % (name, text)
        self._struct = struct.Struct('<' + ''.join(_TYPES[f.type][2] * f.count for f in laid_out))
        assert self._struct.size == self.size
        # a sample is packed from a dict of one value a struct member, an array's elements keyed as 'name[i]':
        # merging and picking run in C, only the arrays given are spread in Python
        self._zeros, keys, self._elements = {}, [], {}
        for f in laid_out:
            zero = False if f.type == 'bool' else b'\0' if f.type == 'char' else 0
            names = [f.name] if f.count == 1 else ['%s[%d]' % (f.name, i) for i in range(f.count)]
            if f.count > 1:
                self._elements[f.name] = names
            keys += names
            self._zeros.update((key, zero) for key in names)
        self._pick = operator.itemgetter(*keys)
        self._arrays = frozenset(self._elements)

    def pack(self, values):
        flat = self._zeros.copy()
        flat.update(values)
        for name in self._arrays.intersection(values):
            flat.update(zip(self._elements[name], values[name]))
        return self._struct.pack(*self._pick(flat))


# msg/versioned/VehicleLocalPosition.msg
VEHICLE_LOCAL_POSITION = Topic('vehicle_local_position', '''
uint64 timestamp
uint64 timestamp_sample
bool xy_valid
bool z_valid
bool v_xy_valid
bool v_z_valid
float32 x
float32 y
float32 z
float32[2] delta_xy
uint8 xy_reset_counter
float32 delta_z
uint8 z_reset_counter
float32 vx
float32 vy
float32 vz
float32 z_deriv
float32[2] delta_vxy
uint8 vxy_reset_counter
float32 delta_vz
uint8 vz_reset_counter
float32 ax
float32 ay
float32 az
float32 heading
float32 heading_var
float32 unaided_heading
float32 delta_heading
uint8 heading_reset_counter
bool heading_good_for_control
float32 tilt_var
bool xy_global
bool z_global
uint64 ref_timestamp
float64 ref_lat
float64 ref_lon
float32 ref_alt
bool dist_bottom_valid
float32 dist_bottom
float32 dist_bottom_var
float32 delta_dist_bottom
uint8 dist_bottom_reset_counter
uint8 dist_bottom_sensor_bitfield
float32 eph
float32 epv
float32 evh
float32 evv
bool dead_reckoning
float32 vxy_max
float32 vz_max
float32 hagl_min
float32 hagl_max_z
float32 hagl_max_xy
''')

# msg/versioned/VehicleGlobalPosition.msg
VEHICLE_GLOBAL_POSITION = Topic('vehicle_global_position', '''
uint64 timestamp
uint64 timestamp_sample
float64 lat
float64 lon
float32 alt
float32 alt_ellipsoid
bool lat_lon_valid
bool alt_valid
float32 delta_alt
float32 delta_terrain
uint8 lat_lon_reset_counter
uint8 alt_reset_counter
uint8 terrain_reset_counter
float32 eph
float32 epv
float32 terrain_alt
bool terrain_alt_valid
bool dead_reckoning
''')

# msg/versioned/VehicleAttitude.msg
VEHICLE_ATTITUDE = Topic('vehicle_attitude', '''
uint64 timestamp
uint64 timestamp_sample
float32[4] q
float32[4] delta_q_reset
uint8 quat_reset_counter
''')

# msg/versioned/VehicleStatus.msg
VEHICLE_STATUS = Topic('vehicle_status', '''
uint64 timestamp
uint64 armed_time
uint64 takeoff_time
uint8 arming_state
uint8 latest_arming_reason
uint8 latest_disarming_reason
uint64 nav_state_timestamp
uint8 nav_state_user_intention
uint8 nav_state
uint8 executor_in_charge
uint8 nav_state_display
uint32 valid_nav_states_mask
uint32 can_set_nav_states_mask
uint16 failure_detector_status
uint8 hil_state
uint8 vehicle_type
bool failsafe
bool failsafe_and_user_took_over
uint8 failsafe_defer_state
bool gcs_connection_lost
uint8 gcs_connection_lost_counter
bool high_latency_data_link_lost
bool is_vtol
bool is_vtol_tailsitter
bool in_transition_mode
bool in_transition_to_fw
uint8 system_type
uint8 system_id
uint8 component_id
bool safety_button_available
bool safety_off
bool power_input_valid
bool usb_connected
bool open_drone_id_system_present
bool open_drone_id_system_healthy
bool parachute_system_present
bool parachute_system_healthy
bool traffic_avoidance_system_present
bool rc_calibration_in_progress
bool calibration_enabled
bool pre_flight_checks_pass
''')
ARMING_STATE_DISARMED, ARMING_STATE_ARMED = 1, 2
ARM_DISARM_REASON_COMMAND_EXTERNAL = 4
ARM_DISARM_REASON_LANDING = 6
ARM_DISARM_REASON_PREFLIGHT_INACTION = 7
ARM_DISARM_REASON_FAILSAFE = 14
VEHICLE_TYPE_ROTARY_WING = 1
# NAVIGATION_STATE_* by the simulator's mode names (sim.mode_util: mavros's, then PX4's own)
NAVIGATION_STATE = {
    'MANUAL': 0, 'ALTCTL': 1, 'POSCTL': 2, 'AUTO.MISSION': 3, 'AUTO.LOITER': 4, 'AUTO.RTL': 5, 'POSCTL.SLOW': 6,
    'ALTITUDE_CRUISE': 8, 'ACRO': 10, 'DESCEND': 12, 'TERMINATION': 13, 'OFFBOARD': 14, 'STABILIZED': 15,
    'AUTO.TAKEOFF': 17, 'AUTO.LAND': 18, 'AUTO.FOLLOW_TARGET': 19, 'AUTO.PRECLAND': 20, 'POSCTL.ORBIT': 21,
    'AUTO.VTOL_TAKEOFF': 22,
}

# msg/versioned/VehicleLandDetected.msg
VEHICLE_LAND_DETECTED = Topic('vehicle_land_detected', '''
uint64 timestamp
bool freefall
bool ground_contact
bool maybe_landed
bool landed
bool in_ground_effect
bool in_descend
bool has_low_throttle
bool vertical_movement
bool horizontal_movement
bool rotational_movement
bool close_to_ground_or_skipped_check
bool at_rest
''')

# msg/versioned/VehicleCommand.msg
VEHICLE_COMMAND = Topic('vehicle_command', '''
uint64 timestamp
float32 param1
float32 param2
float32 param3
float32 param4
float64 param5
float64 param6
float32 param7
uint32 command
uint8 target_system
uint8 target_component
uint8 source_system
uint16 source_component
uint8 confirmation
bool from_external
''')

# msg/versioned/VehicleCommandAck.msg
VEHICLE_COMMAND_ACK = Topic('vehicle_command_ack', '''
uint64 timestamp
uint32 command
uint8 result
uint8 result_param1
int32 result_param2
uint8 target_system
uint16 target_component
bool from_external
''')

# msg/versioned/TrajectorySetpoint.msg
TRAJECTORY_SETPOINT = Topic('trajectory_setpoint', '''
uint64 timestamp
float32[3] position
float32[3] velocity
float32[3] acceleration
float32[3] jerk
float32 yaw
float32 yawspeed
''')

# msg/VehicleLocalPositionSetpoint.msg
VEHICLE_LOCAL_POSITION_SETPOINT = Topic('vehicle_local_position_setpoint', '''
uint64 timestamp
float32 x
float32 y
float32 z
float32 vx
float32 vy
float32 vz
float32[3] acceleration
float32[3] thrust
float32 yaw
float32 yawspeed
''')

# msg/versioned/HomePosition.msg
HOME_POSITION = Topic('home_position', '''
uint64 timestamp
float64 lat
float64 lon
float32 alt
float32 x
float32 y
float32 z
float32 roll
float32 pitch
float32 yaw
bool valid_alt
bool valid_hpos
bool valid_lpos
bool manual_home
uint32 update_count
''')

# msg/versioned/BatteryStatus.msg
BATTERY_STATUS = Topic('battery_status', '''
uint64 timestamp
bool connected
float32 voltage_v
float32 current_a
float32 current_average_a
float32 discharged_mah
float32 remaining
float32 scale
float32 time_remaining_s
float32 temperature
uint8 cell_count
uint8 source
uint8 priority
uint16 capacity
uint16 cycle_count
uint16 average_time_to_empty
uint16 manufacture_date
uint16 state_of_health
uint16 max_error
uint8 id
uint16 interface_error
float32[14] voltage_cell_v
float32 max_cell_voltage_delta
bool is_powering_off
bool is_required
uint8 warning
uint16 faults
float32 full_charge_capacity_wh
float32 remaining_capacity_wh
uint16 over_discharge_count
float32 nominal_voltage
float32 internal_resistance_estimate
float32 ocv_estimate
float32 ocv_estimate_filtered
float32 volt_based_soc_estimate
float32 voltage_prediction
float32 prediction_error
float32 estimation_covariance_norm
''')

# msg/versioned/Event.msg: the logger always subscribes it (src/modules/logger/logger.cpp _event_subscription)
EVENT = Topic('event', '''
uint64 timestamp
uint32 id
uint16 event_sequence
uint8[25] arguments
uint8 log_levels
''')
