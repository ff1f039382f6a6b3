"""The mavros-compatible node: parameters, the FCU (and optional GCS) link, the plugins.

Runs as node `mavros`; every topic and service is private (`~state` is /mavros/state),
so a namespace moves a whole vehicle, as with real mavros. One thread receives MAVLink
and runs the plugins' handlers; it also does the periodic work (our HEARTBEAT, the
connection timeout, scheduled requests). Service calls run in rospy's threads and
wait on events set by that receive thread, so a call waiting for an ACK never delays
setpoints or telemetry.
"""

import math
import select
import threading
import time

import rospy

from offboard_py.mavlink_link import MavlinkLink, SigningKeyError, UrlError, parse_udp_url, read_signing_key
from offboard_py.bridge import (altitude, command, global_position, home_position, imu, local_position,
                                mission, param, setpoint, sys_status)

DEFAULT_FCU_URL = 'udp://:14540@localhost:14557'  # PX4 SITL, as in mavros's px4.launch
PLUGINS = (sys_status.SysStatus, command.Command, setpoint.Setpoint, local_position.LocalPosition,
           global_position.GlobalPosition, altitude.Altitude, imu.Imu, home_position.HomePosition,
           param.Param, mission.Mission)


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
                          ('global_position/frame_id', 'map'), ('signing/key_file', '')):
        value = get(name, default)
        if not isinstance(value, str):
            raise ConfigError('parameter ~%s: expected a string, got %r' % (name, value))
        cfg[name] = value
    for name, default, low, high in (('target_system_id', 1, 1, 255), ('target_component_id', 1, 0, 255),
                                     ('system_id', 1, 1, 255), ('component_id', 240, 1, 255)):
        value = get(name, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError('parameter ~%s: expected a whole number, got %r' % (name, value))
        cfg[name] = int(_number(name, value, low, high))
    for name, default, low, high in (('conn/timeout', 10.0, 0.1, 3600.0), ('conn/heartbeat_rate', 1.0, 0.0, 100.0),
                                     ('cmd/command_ack_timeout', 5.0, 0.1, 600.0)):
        cfg[name] = float(_number(name, get(name, default), low, high))
    for key, name, ports in (('fcu', 'fcu_url', ()), ('gcs', 'gcs_url', (14550, 14551))):
        try:
            cfg[key] = parse_udp_url(cfg[name], *ports) if cfg[name] else None
        except UrlError as err:
            raise ConfigError('parameter ~%s: %s' % (name, err))
    if cfg['fcu'] is None:
        raise ConfigError('parameter ~fcu_url: empty')
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


class Bridge:
    def __init__(self, cfg):
        self.cfg = cfg
        self.target_system = cfg['target_system_id']
        self.target_component = cfg['target_component_id']
        (bind, remote) = cfg['fcu']
        self.link = MavlinkLink(bind, remote, cfg['system_id'], cfg['component_id'])
        self.link.warn = rospy.logwarn
        if cfg['signing']:
            self.link.enable_signing(*cfg['signing'], required=cfg['signing/required'])
        self.mav = self.link.mav
        self.gcs = None
        if cfg['gcs']:
            self.gcs = MavlinkLink(cfg['gcs'][0], cfg['gcs'][1], cfg['system_id'], cfg['component_id'])
            self.link.on_datagram = self.gcs.send_bytes     # FCU -> GCS, raw
            self.gcs.on_datagram = self._send_bytes_to_fcu  # GCS -> FCU, raw
        self._periodic = []  # (period_s, next_s, callback)
        self.connected = False
        self._connection_listeners = []
        self.plugins = [plugin(self) for plugin in PLUGINS]
        self._running = False
        self._thread = None

    # -- services for the plugins ------------------------------------------------------------

    def from_target(self, msg):
        return msg.get_srcSystem() == self.target_system

    def on(self, msg_type, handler):
        """Handle `msg_type` from the target system only."""
        self.link.on(msg_type, lambda msg: handler(msg) if self.from_target(msg) else None)

    def send(self, msg):
        return self.link.send(msg)

    def _send_bytes_to_fcu(self, data):
        self.link.send_bytes(data)

    def every(self, period_s, callback):
        """Call callback(now_s) every period_s from the receive thread."""
        self._periodic.append([period_s, time.monotonic(), callback])

    def on_connection(self, callback):
        """callback(connected) on every change of the FCU connection."""
        self._connection_listeners.append(callback)

    def after_connect(self, delay_s, callback):
        """Call callback() delay_s after every new connection (from a timer thread)."""
        def start(connected):
            if connected:
                timer = threading.Timer(delay_s, callback)
                timer.daemon = True
                timer.start()
        self.on_connection(start)

    def set_connected(self, connected):
        if connected != self.connected:
            self.connected = connected
            for callback in self._connection_listeners:
                callback(connected)

    # -- the receive thread -------------------------------------------------------------------

    def start(self):
        self._running = True
        self._thread = threading.Thread(target=self._loop, name='mavlink-receive', daemon=True)
        self._thread.start()

    def _loop(self):
        links = [self.link] + ([self.gcs] if self.gcs else [])
        while self._running and not rospy.is_shutdown():
            try:
                readable, _, _ = select.select(links, [], [], 0.02)
            except (OSError, ValueError):
                break  # sockets closed at shutdown
            for link in readable:
                link.receive()
            now = time.monotonic()
            for task in self._periodic:
                if now >= task[1]:
                    task[1] = max(task[1] + task[0], now)
                    try:
                        task[2](now)
                    except Exception:  # a plugin bug must not stop the link
                        rospy.logerr('periodic task %r failed', task[2], exc_info=True)

    def stop(self):
        self._running = False
        if self._thread:
            self._thread.join(timeout=2.0)
        self.link.close()
        if self.gcs:
            self.gcs.close()


def main():
    rospy.init_node('mavros')
    try:
        cfg = read_config(lambda name, default: rospy.get_param('~' + name, default))
        bridge = Bridge(cfg)
    except (ConfigError, UrlError, OSError) as err:
        rospy.logfatal('mavros bridge: %s', err)
        return 2
    rospy.loginfo('FCU: %s (bound to %s:%d, %s)', cfg['fcu_url'], bridge.link.bind[0], bridge.link.bind[1],
                  'sending to %s:%d' % bridge.link.remote if bridge.link.remote else 'waiting for the FCU to talk')
    if cfg['signing']:
        rospy.loginfo('MAVLink signing on (key %s): unsigned input is %s', cfg['signing/key_file'],
                      'rejected' if cfg['signing/required'] else 'accepted')
    bridge.start()
    try:
        rospy.spin()
    finally:
        bridge.stop()
    return 0
