"""A test node's subscriptions, mended where rospy's registration race left one without its publisher.

rospy's registration thread (rospy.impl.registration.RegManager) keeps only the newest publisher list it was
handed for a topic. A subscriber registers with the master and hands on the answer, the publishers the master
knew then; a publisher that registers meanwhile is announced by the master's publisherUpdate. When the node's
thread is starved between the master's answer and handing it on, the older answer (no publisher yet) comes
after the announcement and replaces it, and the subscription never connects. A fresh-clone run beside two busy
loops lost the test's `mavros/state` that way: 90 s of "not connected" while the vehicle flew.

So a subscription of this process without a connection for MEND_AFTER_WALL_S while the master lists
publishers is handed the master's list again, as the master hands it (publisherUpdate on this node's own
XML-RPC), and that is logged with the topic. rospy drops a second connection to the same publisher, so handing
it on twice does no harm.
"""

import time
import xmlrpc.client

import rosgraph
import rospy
from rospy.impl.registration import get_topic_manager

MEND_AFTER_WALL_S = 2.0  # a connection normally comes within milliseconds of the publisher list
LOOK_EVERY_WALL_S = 1.0


def _master_publishers(topic, topic_type):
    """The publishers' XML-RPC URIs the master lists for topic (registerSubscriber again: the master keeps one
    registration per node and topic, and answers with its list)."""
    return rosgraph.Master(rospy.get_name()).registerSubscriber(topic, topic_type, rospy.get_node_uri())


def _hand_on(topic, uris):
    xmlrpc.client.ServerProxy(rospy.get_node_uri()).publisherUpdate('/master', topic, uris)


def _subscriptions():
    """[(topic, type, connections)] of this process's subscriptions."""
    manager = get_topic_manager()
    out = []
    for topic, topic_type in manager.get_subscriptions():
        impl = manager.get_subscriber_impl(topic)
        if impl is not None:
            out.append((topic, topic_type, impl.get_num_connections()))
    return out


class SubscriptionMender:
    """look() now and then (OffboardTestCase.guard does, in every wait): mends what rospy's race left."""

    def __init__(self, clock=time.monotonic, subscriptions=_subscriptions, master_publishers=_master_publishers,
                 hand_on=_hand_on, say=rospy.logwarn, own_uri=rospy.get_node_uri):
        self._clock, self._subscriptions, self._own_uri = clock, subscriptions, own_uri
        self._master_publishers, self._hand_on, self._say = master_publishers, hand_on, say
        self._unconnected_since = {}
        self._next_look_s = 0.0
        self.mended = []  # (topic, uris) handed on again

    def look(self):
        now_s = self._clock()
        if now_s < self._next_look_s:
            return
        self._next_look_s = now_s + LOOK_EVERY_WALL_S
        seen = set()
        for topic, topic_type, connections in self._subscriptions():
            seen.add(topic)
            if connections:
                self._unconnected_since.pop(topic, None)
                continue
            since_s = self._unconnected_since.setdefault(topic, now_s)
            if now_s - since_s < MEND_AFTER_WALL_S:
                continue
            self._unconnected_since[topic] = now_s  # the next try after as long again
            try:
                # not this node's own publications: those connect within the process, and a test's publisher
                # that comes and goes (bridge.test's) is no race of the master's
                own = self._own_uri()
                uris = [uri for uri in self._master_publishers(topic, topic_type) if uri != own]
                if uris:
                    self._hand_on(topic, uris)
            except (OSError, rosgraph.MasterException, xmlrpc.client.Error) as err:
                self._say('the subscription to %s has had no connection for %.0f wall seconds, and asking the '
                          'master for its publishers failed: %s' % (topic, now_s - since_s, err))
                continue
            if uris and (topic, list(uris)) not in self.mended:  # said once (a publisher killed stays listed)
                self.mended.append((topic, list(uris)))
                self._say('the subscription to %s had no connection for %.0f wall seconds while the master lists '
                          'its publishers %s: handed on again (rospy kept an older, empty list)'
                          % (topic, now_s - since_s, ', '.join(uris)))
        for topic in set(self._unconnected_since) - seen:
            del self._unconnected_since[topic]
