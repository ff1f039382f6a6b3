"""The fake FCU link, in-memory ROS endpoints and clock that the bridge's offline tests build the
real Bridge on (test_bridge_plugins, test_bridge_sys_time). Not a test module: the tests import it.

The FakeFcu packs its frames with its own pymavlink codec (system 1, component 1) and hands the
bytes to the bridge; what a plugin sends is packed by the bridge's codec and parsed back by the
FakeFcu, which may answer at once from a per-message-type script. Topics, services and
subscriptions live in FakeRos; time in FakeClock, moved by the test.
"""

import collections
import threading
import time

import pytest
import rospy

from offboard_py.bridge.config import read_config
from offboard_py.bridge.core import Bridge
from offboard_py.dialect import mavlink

OFFBOARD = 6 << 16                  # PX4 custom_mode: main mode 6
AUTO_LOITER = (4 << 16) | (3 << 24)  # main mode 4 (AUTO), sub-mode 3 (LOITER)
BUILD = mavlink.MAVLink(None)       # builds messages; whoever sends one packs it with its own ids


# -- fakes ------------------------------------------------------------------------------------

class FakeLink:
    """The bridge's end of the FCU link, in memory, with MavlinkLink's on/send/mav."""

    def __init__(self):
        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=mavlink.MAV_COMP_ID_UDP_BRIDGE)
        self.handlers = {}
        self.raw_hooks = {}
        self.stats = collections.Counter()
        self.fcu = None
        self._lock = threading.Lock()

    def on(self, msg_type, handler, needed=None):
        """Every message goes to every handler: the link's skipping of unneeded types is MavlinkLink's
        (test_wire, and test_unneeded_types_are_not_decoded below)."""
        self.handlers.setdefault(msg_type, []).append(handler)

    def on_raw(self, msg_type, hook):
        """A kept frame is given before the handlers of the same message, as MavlinkLink does."""
        self.raw_hooks.setdefault(msg_type, []).append(hook)

    def on_frames(self, hook, needed=None):
        """Raw frames are MavlinkLink's (test_link_partner); this link hands out messages only."""
        self.frame_hook = (hook, needed)

    def needs_changed(self):
        """Nothing to ask again: every message goes to every handler here."""

    def last_seq(self, source):
        """Sequence numbers are MavlinkLink's (test_wire): none are kept here."""
        return 0

    def send(self, msg):
        with self._lock:
            data = msg.pack(self.mav)
        self.fcu.receive(data)
        return True

    def handle_datagram(self, data):
        for msg in mavlink.MAVLink(None).parse_buffer(data) or []:
            for hook in self.raw_hooks.get(msg.get_type(), ()):
                hook(bytes(msg.get_msgbuf()))
            for handler in self.handlers.get(msg.get_type(), ()):
                handler(msg)


class FakeFcu:
    """The autopilot's end: sends frames as (1, 1), records what it gets, answers by script."""

    def __init__(self, link):
        self.link = link
        link.fcu = self
        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.received = []
        self.answers = {}  # message type -> function(msg) returning the messages to send back

    def send(self, msg, codec=None):
        self.link.handle_datagram(msg.pack(codec or self.mav))

    def receive(self, data):
        for msg in mavlink.MAVLink(None).parse_buffer(data) or []:
            self.received.append(msg)
            for reply in self.answers.get(msg.get_type(), lambda _msg: ())(msg):
                self.send(reply)

    def got(self, msg_type):
        return [m for m in self.received if m.get_type() == msg_type]


class FakePublisher:
    """rospy's Publisher as the bridge sees it: setting `connections` tells the bridge, as rospy's
    subscriber_listener does when a subscriber comes or goes."""

    def __init__(self, latch, queue_size, on_subscribers):
        self.latch, self.queue_size = latch, queue_size
        self.messages = []
        self.on_subscribers = on_subscribers
        self._connections = 1

    @property
    def connections(self):
        return self._connections

    @connections.setter
    def connections(self, count):
        self._connections = count
        self.on_subscribers()

    def publish(self, msg):
        self.messages.append(msg)

    def get_num_connections(self):
        return self.connections


class FakeRos:
    def __init__(self, node_name='/mavros'):
        self.topics, self.services, self.subscriptions = {}, {}, {}
        self.params = {}
        self.name = node_name

    def node_name(self):
        return self.name

    def get_param(self, name, default):
        """A name with slashes reads into the tree, as the parameter server does: `~param` is the
        dictionary that `~param/NAME`s were set in."""
        node = self.params
        for part in name.split('/'):
            if not isinstance(node, dict) or part not in node:
                return default
            node = node[part]
        return node

    def set_param(self, name, value):
        *path, leaf = name.split('/')
        node = self.params
        for part in path:
            node = node.setdefault(part, {})
        node[leaf] = value

    def publisher(self, name, _data_class, queue_size, latch, on_subscribers):
        self.topics[name] = FakePublisher(latch, queue_size, on_subscribers)
        return self.topics[name]

    def subscriber(self, name, _data_class, callback):
        self.subscriptions[name] = callback

    def service(self, name, _service_class, handler):
        self.services[name] = handler

    @staticmethod
    def now():
        return rospy.Time(1000)

    @staticmethod
    def is_shutdown():
        return False


class FakeClock:
    """The bridge's clock, set by the test. It stands still for HOLD_S of wall time after each setting,
    then runs on at wall speed, so a wait for an answer that never comes still ends (Bridge.wait
    watches this clock, not the wall)."""

    HOLD_S = 0.2

    def __init__(self, now_s=100.0):
        self.now_s = now_s

    @property
    def now_s(self):
        return self._base_s + max(0.0, time.monotonic() - self._set_at - self.HOLD_S)

    @now_s.setter
    def now_s(self, value):
        self._base_s, self._set_at = value, time.monotonic()

    def __call__(self):
        return self.now_s


class Rig:
    """One bridge with the given plugins on a fake link."""

    def __init__(self, *plugins, node_name='/mavros', **params):
        cfg = read_config(lambda name, default: params.get(name.replace('/', '__'), default))
        self.link, self.ros, self.clock = FakeLink(), FakeRos(node_name), FakeClock()
        self.fcu = FakeFcu(self.link)
        self.bridge = Bridge(cfg, self.link, self.ros, plugins, clock=self.clock)
        self.plugin = self.bridge.plugins[0]

    def call(self, service, request):
        return self.ros.services[service](request)

    def published(self, topic):
        return self.ros.topics[topic].messages

    def tick(self, now_s):
        self.clock.now_s = now_s
        self.bridge.run_due(now_s)


def heartbeat(base_mode=mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, custom_mode=AUTO_LOITER):
    return BUILD.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, base_mode, custom_mode,
                                  mavlink.MAV_STATE_STANDBY)


def same_rotation(q, expected):
    """q and -q are the same rotation."""
    return tuple(q) == pytest.approx(expected) or tuple(-c for c in q) == pytest.approx(expected)


def wait_until(condition, timeout_s=2.0):
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


# -- the node's ROS interface -------------------------------------------------------------------
