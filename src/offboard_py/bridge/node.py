"""The mavros-compatible node: parameters, the FCU (and optional GCS) link, the plugins.

Runs as node `mavros`; every topic and service is private (`~state` is /mavros/state),
so a namespace moves a whole vehicle, as with real mavros. One thread receives MAVLink
and runs the plugins' handlers; it also does the periodic work (our HEARTBEAT, the
connection timeout, scheduled requests). Service calls run in rospy's threads and
wait on events set by that receive thread, so a call waiting for an ACK never delays
setpoints or telemetry.
"""

import logging
import select
import sys
import threading
import time

import rospy

from offboard_py.bridge.config import ConfigError, read_config
from offboard_py.master import MasterTimeout, master_timeout_from_argv, wait_for_master
from offboard_py.mavlink_link import MavlinkLink, UrlError
from offboard_py.bridge import (altitude, command, global_position, home_position, imu, local_position,
                                mission, param, setpoint, sys_status)

PLUGINS = (sys_status.SysStatus, command.Command, setpoint.Setpoint, local_position.LocalPosition,
           global_position.GlobalPosition, altitude.Altitude, imu.Imu, home_position.HomePosition,
           param.Param, mission.Mission)


class Bridge:
    def __init__(self, cfg):
        self.cfg = cfg
        self.target_system = cfg['target_system_id']
        self.target_component = cfg['target_component_id']
        (bind, remote) = cfg['fcu']
        self.link = MavlinkLink(bind, remote, cfg['system_id'], cfg['component_id'])
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


class _ToRosout(logging.Handler):
    """What the shared link layer logs (signing rejections, handler errors) goes to /rosout."""

    def emit(self, record):
        text = self.format(record)
        (rospy.logerr if record.levelno >= logging.ERROR else
         rospy.logwarn if record.levelno >= logging.WARNING else rospy.loginfo)(text)


def main():
    try:
        wait_for_master('mavros', master_timeout_from_argv(sys.argv))
    except (ValueError, MasterTimeout) as err:
        print(err, file=sys.stderr)
        return 2 if isinstance(err, ValueError) else 1
    except KeyboardInterrupt:
        return 0
    rospy.init_node('mavros')
    handler = _ToRosout()
    handler.setFormatter(logging.Formatter('%(message)s'))
    logging.getLogger('offboard_py').addHandler(handler)
    logging.getLogger('offboard_py').setLevel(logging.INFO)
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
