"""The bridge's node parameters, read and checked without ROS (get(name, default) is rospy.get_param)."""

import logging
import math

from offboard_py.dialect import mavlink
from offboard_py.mavlink_link import UrlError, parse_udp_url
from offboard_py.signing import SigningKeyError, read_signing_key

DEFAULT_FCU_URL = 'udp://:14540@localhost:14557'  # PX4 SITL, as in mavros's px4.launch


class ConfigError(ValueError):
    """A node parameter the bridge cannot run with; the message names it."""


def _number(name, value, low, high):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError('parameter ~%s: expected a number, got %r' % (name, value))
    if not low <= value <= high:
        raise ConfigError('parameter ~%s: %g is outside [%g, %g]' % (name, value, low, high))
    return value


def read_config(get):
    """All node parameters through get(name, default), checked. Raises ConfigError."""
    cfg = {}
    for name, default in (('fcu_url', DEFAULT_FCU_URL), ('gcs_url', ''), ('local_position/frame_id', 'map'),
                          ('global_position/frame_id', 'map'), ('signing/key_file', ''),
                          ('local_position/tf/frame_id', 'map'), ('local_position/tf/child_frame_id', 'base_link'),
                          ('global_position/child_frame_id', 'base_link'), ('imu/frame_id', 'base_link')):
        value = get(name, default)
        if not isinstance(value, str):
            raise ConfigError('parameter ~%s: expected a string, got %r' % (name, value))
        cfg[name] = value
    # component ids as mavros's px4.launch: we talk to the autopilot and are a UDP bridge
    for name, default, low, high in (('target_system_id', 1, 1, 255),
                                     ('target_component_id', mavlink.MAV_COMP_ID_AUTOPILOT1, 0, 255),
                                     ('system_id', 1, 1, 255), ('component_id', mavlink.MAV_COMP_ID_UDP_BRIDGE, 1, 255)):
        value = get(name, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError('parameter ~%s: expected a whole number, got %r' % (name, value))
        cfg[name] = int(_number(name, value, low, high))
    for name, default, low, high in (('conn/timeout', 10.0, 0.1, 3600.0), ('conn/heartbeat_rate', 1.0, 0.0, 100.0),
                                     ('cmd/command_ack_timeout', 5.0, 0.1, 600.0),
                                     ('global_position/gps_uere', 1.0, 0.0, 1000.0),
                                     ('global_position/rot_covariance', 99999.0, 0.0, 1e12),
                                     # px4_config.yaml's 1.0; below 0, as mavros without it, thrust is not sent
                                     ('setpoint_raw/thrust_scaling', 1.0, -1e6, 1e6)):
        cfg[name] = float(_number(name, get(name, default), low, high))
    # mavros's conn/heartbeat_mav_type: a MAV_TYPE name (utils::mav_type_from_str); an unknown one is
    # GENERIC with mavros's error. PX4 sends STATUSTEXT only to a link that hears a GCS heartbeat.
    mav_type = get('conn/heartbeat_mav_type', 'ONBOARD_CONTROLLER')
    if not isinstance(mav_type, str):
        raise ConfigError('parameter ~conn/heartbeat_mav_type: expected a MAV_TYPE name such as GCS, got %r'
                          % (mav_type,))
    cfg['conn/heartbeat_mav_type'] = mav_type
    read_time_config(get, cfg)
    read_imu_config(get, cfg)
    for key, name in (('fcu', 'fcu_url'), ('gcs', 'gcs_url')):
        try:  # mavconn's defaults for both: bind 14555, remote 14550
            cfg[key] = parse_udp_url(cfg[name]) if cfg[name] else None
        except UrlError as err:
            raise ConfigError('parameter ~%s: %s' % (name, err))
    if cfg['fcu'] is None:
        raise ConfigError('parameter ~fcu_url: empty')
    # mavros reads a list (a battery each, first only here); a single number is not a list to it: 10 V
    min_voltage = get('sys/min_voltage', [10.0])
    cfg['sys/min_voltage'] = (float(_number('sys/min_voltage', min_voltage[0], 0.0, 1000.0))
                              if isinstance(min_voltage, list) and min_voltage else 10.0)
    for name, default in (('local_position/tf/send', False), ('global_position/use_relative_alt', True),
                          ('sys/disable_diag', False), ('setpoint_attitude/use_quaternion', False),
                          ('setpoint_attitude/reverse_thrust', False)):
        value = get(name, default)
        if not isinstance(value, bool):
            raise ConfigError('parameter ~%s: expected true or false, got %r' % (name, value))
        cfg[name] = value
    required = get('signing/required', True)
    if not isinstance(required, bool):
        raise ConfigError('parameter ~signing/required: expected true or false, got %r' % (required,))
    cfg['signing/required'] = required
    cfg['signing'] = None
    if cfg['signing/key_file']:
        try:
            cfg['signing'] = read_signing_key(cfg['signing/key_file'])
        except SigningKeyError as err:
            raise ConfigError('parameter ~signing/key_file: %s' % err)
    return cfg


# mavros sys_time's parameters and defaults; the filter's go to cfg['time/filter'] as keyword arguments
TIME_FILTER_PARAMS = (('time/timesync_alpha_initial', 'alpha_initial', 0.05), ('time/timesync_beta_initial', 'beta_initial', 0.05),
                      ('time/timesync_alpha_final', 'alpha_final', 0.003), ('time/timesync_beta_final', 'beta_final', 0.003))
TIME_LIMIT_PARAMS = (('time/convergence_window', 'convergence_window', 500),
                     ('time/max_rtt_sample', 'max_rtt_ms', 10), ('time/max_deviation_sample', 'max_deviation_ms', 100),
                     ('time/max_consecutive_high_rtt', 'max_high_rtt', 5),
                     ('time/max_consecutive_high_deviation', 'max_high_deviation', 5))


def read_time_config(get, cfg):
    from offboard_py.bridge.sys_time import MODES
    mode = get('time/timesync_mode', 'MAVLINK')
    if mode not in MODES:
        raise ConfigError('parameter ~time/timesync_mode: %r is not one of %s (ONBOARD is not supported)'
                          % (mode, ', '.join(MODES)))
    cfg['time/timesync_mode'] = mode
    source = get('time/time_ref_source', 'fcu')
    if not isinstance(source, str):
        raise ConfigError('parameter ~time/time_ref_source: expected a string, got %r' % (source,))
    cfg['time/time_ref_source'] = source
    cfg['conn/timesync_rate'] = float(_number('conn/timesync_rate', get('conn/timesync_rate', 10.0), 0.0, 100.0))
    # mavros's default is 0 (none); px4.launch's px4_config.yaml sets 1.0, and the bridge follows px4.launch
    cfg['conn/system_time_rate'] = float(_number('conn/system_time_rate', get('conn/system_time_rate', 1.0), 0.0,
                                                 100.0))
    filter_args = {}
    for name, arg, default in TIME_FILTER_PARAMS:
        filter_args[arg] = float(_number(name, get(name, default), 0.0, 1.0))
    for name, arg, default in TIME_LIMIT_PARAMS:
        value = get(name, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError('parameter ~%s: expected a whole number, got %r' % (name, value))
        filter_args[arg] = int(_number(name, value, 1, 1000000))
    cfg['time/filter'] = filter_args


# mavros imu's standard deviations (px4_config.yaml's values; mavros's defaults are the same) for the
# covariances of imu/data, imu/data_raw and imu/mag; 0 means unknown (element 0 is -1)
IMU_STDEV_PARAMS = (('imu/linear_acceleration_stdev', 0.0003), ('imu/angular_velocity_stdev', 0.02 * math.pi / 180.0),
                    ('imu/orientation_stdev', 1.0), ('imu/magnetic_stdev', 0.0))


def read_imu_config(get, cfg):
    """The imu plugin's standard deviations. A value that is not a number is mavros's default, with a
    warning naming it, as mavros reads it (px4_config.yaml's angular_velocity_stdev is the string
    "0.0003490659 // 0.02 degrees", whose default is the same number); a negative or unfinite one is an error."""
    for name, default in IMU_STDEV_PARAMS:
        value = get(name, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            logging.getLogger(__name__).warning('parameter ~%s: %r is not a number; using %g, as mavros does',
                                                name, value, default)
            value = default
        cfg[name] = float(_number(name, value, 0.0, 1e6))
