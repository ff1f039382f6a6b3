"""The mavros-compatible node: parameters, the FCU (and optional GCS) link, rospy, the plugins.

Runs as node `mavros`; every topic and service is private (`~state` is /mavros/state),
so a namespace moves a whole vehicle, as with real mavros. The plugins and what they are
given live in core.py and one module each; this module is their rospy wiring.
"""

import logging
import sys
import time

import rospy

from offboard_py import ros_participant, tcpros_out
from offboard_py.bridge.config import ConfigError, read_config
from offboard_py.bridge.core import Bridge
from offboard_py.dialect import check_pymavlink_version
from offboard_py.master import await_master_from_argv
from offboard_py.mavlink_link import MavlinkLink, UrlError
from offboard_py.stream_watch import StreamWatch
from offboard_py.bridge import (altitude, battery, command, diagnostics, global_position, home_position, imu,
                                local_position, mavlink_passthrough, mission, param, rc_io, setpoint,
                                setpoint_attitude, statustext, sys_status, sys_time, tf_frames, vfr_hud)

PLUGINS = (sys_status.SysStatus, sys_time.SysTime, command.Command, setpoint.Setpoint, local_position.LocalPosition,
           global_position.GlobalPosition, altitude.Altitude, imu.Imu, home_position.HomePosition,
           param.Param, mission.Mission, battery.Battery, statustext.StatusTexts, vfr_hud.VfrHud, rc_io.RcIo,
           setpoint_attitude.SetpointAttitude, mavlink_passthrough.MavlinkPassthrough, diagnostics.Diagnostics,
           tf_frames.TfFrames)


class _SubscribersMoved(rospy.SubscribeListener):
    def __init__(self, callback):
        super().__init__()
        self.callback = callback

    def peer_subscribe(self, _topic_name, _topic_publish, _peer_publish):
        self.callback()

    def peer_unsubscribe(self, _topic_name, _num_peers):
        self.callback()


class RospyEndpoints:
    """The plugins' ROS side in the running node: names as given (`~...` is private to the node)."""

    def __init__(self):
        self.flusher = tcpros_out.Flusher()
        # the setpoint streams by publisher, for the governed clock; a silent one holds it longer while its
        # node's process waits for the CPU
        self.publishers = ros_participant.PublisherProcesses(rospy.get_name())
        self.streams = StreamWatch(runnable=self.publishers.waits_for_cpu)

    def publisher(self, name, data_class, queue_size, latch, on_subscribers):
        """on_subscribers() is called when the topic gains or loses a subscriber. A subscriber's
        messages are written in the publishing thread, never blocking it (tcpros_out)."""
        return tcpros_out.Publisher(name, data_class, queue_size, self.flusher, latch=latch,
                                    subscriber_listener=_SubscribersMoved(on_subscribers))

    def subscriber(self, name, data_class, callback):
        if 'setpoint' in name:  # when each publisher's setpoints came, in simulated and wall time
            handle = callback

            def callback(msg):
                header = getattr(msg, '_connection_header', None) or {}
                publisher = header.get('callerid', '?')
                self.streams.arrived(publisher, rospy.get_time(), time.monotonic())
                self.publishers.seen(publisher)
                handle(msg)
        # setpoints: each one matters and waits for no other, so no Nagle batching
        return rospy.Subscriber(name, data_class, callback, queue_size=10, tcp_nodelay=True)

    @staticmethod
    def service(name, service_class, handler):
        return rospy.Service(name, service_class, handler)

    @staticmethod
    def now():
        return rospy.Time.now()

    @staticmethod
    def get_param(name, default):
        return rospy.get_param(name, default)

    @staticmethod
    def set_param(name, value):
        rospy.set_param(name, value)

    @staticmethod
    def is_shutdown():
        return rospy.is_shutdown()

    @staticmethod
    def node_name():
        return rospy.get_name()


def open_links(cfg):
    """The FCU link (signed if configured) and the GCS link or None, from the checked parameters."""
    def open_link(url, name, peer=None):
        return MavlinkLink(url.bind, url.remote, cfg['system_id'], cfg['component_id'],
                           learn_remote=not url.permanent, broadcast=url.broadcast, name=name, peer=peer)
    # the FCU link follows only the autopilot itself: a flood from another port cannot divert it
    link = open_link(cfg['fcu'], 'udp0', peer=(cfg['target_system_id'], cfg['target_component_id']))
    if cfg['signing']:
        link.enable_signing(*cfg['signing'], required=cfg['signing/required'])
    gcs = open_link(cfg['gcs'], 'udp1') if cfg['gcs'] else None
    return link, gcs


def log_links(cfg, link, gcs):
    """What mavros says about its links at start."""
    rospy.loginfo('FCU URL: %s', cfg['fcu_url'])
    for mav_link in (link, gcs):
        if mav_link is None:
            rospy.loginfo('GCS bridge disabled')
            continue
        if mav_link is gcs:
            rospy.loginfo('GCS URL: %s', cfg['gcs_url'])
        rospy.loginfo('%s: Bind address: %s:%d', mav_link.name, *mav_link.bind)
        if mav_link.remote:
            rospy.loginfo('%s: Remote address: %s:%d', mav_link.name, *mav_link.remote)
        else:
            rospy.loginfo('%s: Remote address: learned from the first packet', mav_link.name)


class _ToRosout(logging.Handler):
    """What the shared link layer logs (signing rejections, handler errors) goes to /rosout."""

    def emit(self, record):
        text = self.format(record)
        (rospy.logerr if record.levelno >= logging.ERROR else
         rospy.logwarn if record.levelno >= logging.WARNING else rospy.loginfo)(text)


def ros_clock():
    """The bridge's clock: ROS time under /use_sim_time (it then follows /clock, as mavros's timers
    do), else the monotonic clock, which no change of the system time can move."""
    if rospy.get_param('/use_sim_time', False):
        return rospy.get_time
    return time.monotonic


def _earliest(*times):
    """The earliest of the times that are not None, or None."""
    given = [t for t in times if t is not None]
    return min(given) if given else None


def _clock_limit(endpoints, bridge):
    """How far the governed clock may run for this bridge's sake: its receive loop's next task and the datagrams
    it has still to read (Bridge.unread_since_s), and the setpoint streams that may be starved rather than stopped
    (offboard_py.stream_watch); a stream given up is said."""
    wall_s = time.monotonic()  # one reading for both: a stream's process is looked at once a tick
    for publisher, last_s, silent_s in endpoints.streams.let_go(wall_s):
        rospy.loginfo('the setpoints from %s stopped at %.2f s and have not come for %.1f wall seconds: the clock '
                      'goes on without them (PX4 takes the offboard signal as lost after COM_OF_LOSS_T)',
                      publisher, last_s, silent_s)
    return _earliest(endpoints.streams.limit(wall_s), bridge.next_task_s, bridge.unread_since_s)


def main():
    exit_code = await_master_from_argv('mavros')
    if exit_code is not None:
        return exit_code
    try:
        rospy.init_node('mavros')
        handler = _ToRosout()
        handler.setFormatter(logging.Formatter('%(message)s'))
        logging.getLogger('offboard_py').addHandler(handler)
        logging.getLogger('offboard_py').setLevel(logging.INFO)
        check_pymavlink_version()  # to /rosout, through the handler above
        cfg = read_config(lambda name, default: rospy.get_param('~' + name, default))
        link, gcs = open_links(cfg)
        endpoints = RospyEndpoints()
        bridge = Bridge(cfg, link, endpoints, PLUGINS, gcs=gcs, clock=ros_clock())
    except (ConfigError, UrlError, OSError) as err:
        rospy.logfatal('mavros bridge: %s', err)
        return 2
    except (rospy.ROSException, KeyboardInterrupt) as err:
        # stopped while starting (rostest teardown, Ctrl-C): say so in one line, no traceback
        if rospy.is_shutdown() or isinstance(err, KeyboardInterrupt):
            print('mavros bridge: stopped while starting', file=sys.stderr)
            return 0
        print('mavros bridge: cannot start: %s' % err, file=sys.stderr)
        return 1
    log_links(cfg, link, gcs)
    if cfg['signing']:
        rospy.loginfo('MAVLink signing on (key %s): unsigned input is %s', cfg['signing/key_file'],
                      'rejected' if cfg['signing/required'] else 'accepted')
    bridge.start()
    # the governed clock waits for this bridge, and for a node whose setpoint stream here has stalled
    participant = ros_participant.join('bridge %s' % rospy.get_name(), limit=lambda: _clock_limit(endpoints, bridge))
    try:
        rospy.spin()
    finally:
        if participant is not None:
            participant.leave()
        bridge.stop()
    return 0
