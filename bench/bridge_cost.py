#!/usr/bin/env python3
"""Where the bridge's time goes on PX4's stream, without sockets' wake-ups: the recorded hover
(bench/data/px4-hover-replay.json.xz) handed datagram by datagram to the bridge's FCU link
(MavlinkLink.handle_datagram) with every plugin of the node loaded, in memory (no ROS master; the topics
have no subscriber but ~state, as with the tutorial's offb_node). Prints the Python time per datagram, what
it comes to at PX4's 406 datagrams a second, and with --profile the functions that take it (cProfile).

    python bench/bridge_cost.py [--passes 3] [--profile] [--subscribed all|state]

Opens one UDP socket on loopback (the link's): run it in a network namespace of its own.
"""

import argparse
import cProfile
import os
import pstats
import sys
import time

import rospy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import px4_replay  # noqa: E402
from offboard_py.bridge import node  # noqa: E402
from offboard_py.bridge.config import read_config  # noqa: E402
from offboard_py.bridge.core import Bridge  # noqa: E402
from offboard_py.mavlink_link import MavlinkLink  # noqa: E402


class Publisher:
    def __init__(self, connections):
        self.connections, self.count = connections, 0

    def publish(self, _msg):
        self.count += 1

    def get_num_connections(self):
        return self.connections


class Ros:
    """rospy's part in memory: publishing is counted, not serialised (rospy's cost is not measured here)."""

    def __init__(self, subscribed):
        self.subscribed, self.topics = subscribed, {}

    def publisher(self, name, _cls, queue_size, latch, on_subscribers):
        self.topics[name] = Publisher(1 if self.subscribed == 'all' or name == '~state' else 0)
        return self.topics[name]

    def subscriber(self, *_args):
        pass

    def service(self, *_args):
        pass

    @staticmethod
    def now():
        return rospy.Time.from_sec(time.time())

    @staticmethod
    def get_param(_name, default):
        return default

    @staticmethod
    def is_shutdown():
        return False

    @staticmethod
    def node_name():
        return '/mavros'


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--passes', type=int, default=3)
    p.add_argument('--profile', action='store_true')
    p.add_argument('--subscribed', choices=('state', 'all'), default='state')
    args = p.parse_args()
    data = px4_replay.load()
    datagrams = [bytes.fromhex(frame) for _, frame in data['stream']]
    rate = len(datagrams) / (data['window_us'] / 1e6)
    cfg = read_config(lambda name, default: default)
    link = MavlinkLink(('127.0.0.1', 0), None, cfg['system_id'], cfg['component_id'],
                       peer=(cfg['target_system_id'], cfg['target_component_id']))
    bridge = Bridge(cfg, link, Ros(args.subscribed), node.PLUGINS)
    sender = ('127.0.0.1', 14580)
    handle = link.handle_datagram
    for data_ in datagrams[:2000]:  # warm: the connection, the readers made once per type
        handle(data_, sender)
    profiler = cProfile.Profile() if args.profile else None
    t0 = time.perf_counter()
    if profiler:
        profiler.enable()
    for _ in range(args.passes):
        for data_ in datagrams:
            handle(data_, sender)
    if profiler:
        profiler.disable()
    per = (time.perf_counter() - t0) / (args.passes * len(datagrams))
    print('%d datagrams: %.1f us each; at %.0f datagrams/s: %.2f %% of one core (subscribed: %s)'
          % (args.passes * len(datagrams), per * 1e6, rate, per * rate * 100.0, args.subscribed))
    if profiler:
        pstats.Stats(profiler).sort_stats('tottime').print_stats(25)
    link.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
