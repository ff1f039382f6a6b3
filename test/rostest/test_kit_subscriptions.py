#!/usr/bin/env python3
"""The test kit mends a subscription that rospy's registration race left without its publisher
(offboard_py.testing.subscriptions): the race's effect made on purpose, on a real master and real topics."""

import sys
import time

import rospy
import rostest
from rospy.impl.registration import RegManager, get_registration_listeners
from std_msgs.msg import String

from offboard_py.testing.processes import OutputProcess
from offboard_py.testing.rostest_common import OffboardTestCase

PKG = 'offboard_py'
TOPIC = '/kit_probe'
STUCK_WALL_S = 3.0  # longer than a connection takes, even on a busy machine (milliseconds)
# the publisher, a node of its own (the kit leaves this node's own publications to rospy)
PUBLISHER = '''
import rospy
from std_msgs.msg import String
rospy.init_node('kit_probe_publisher')
pub = rospy.Publisher('%s', String, queue_size=10)
rate = rospy.Rate(10)
while not rospy.is_shutdown():
    pub.publish(String('mended'))
    rate.sleep()
''' % TOPIC


class KitSubscriptionTest(OffboardTestCase):
    def test_a_subscription_left_without_its_publisher_is_mended(self):
        manager = next(l for l in get_registration_listeners().listeners if isinstance(l, RegManager))
        publisher = OutputProcess([sys.executable, '-c', PUBLISHER])
        self.addCleanup(publisher.wait_exit, 10.0)
        self.addCleanup(publisher.proc.terminate)
        self.wait_until(lambda: TOPIC in [t for t, _ in rospy.get_published_topics()], 20.0,
                        'the publisher node advertising %s' % TOPIC, min_wall_s=20.0)
        handed_on = manager.publisher_update
        dropped = []
        # the race's effect: the master's answer (the publisher) never reaches the registration thread, as when
        # an older, empty list replaces it
        manager.publisher_update = lambda topic, uris: dropped.append((topic, uris)) if topic == TOPIC \
            else handed_on(topic, uris)
        try:
            got = []
            sub = rospy.Subscriber(TOPIC, String, got.append)
        finally:
            manager.publisher_update = handed_on
        self.assertEqual([topic for topic, _ in dropped], [TOPIC], 'the subscriber registered and was answered')
        time.sleep(STUCK_WALL_S)  # rospy alone: no connection, while the publisher publishes at 10 Hz
        self.assertEqual(sub.get_num_connections(), 0, 'rospy connected by itself: the race was not made')
        self.assertEqual(got, [])
        self.wait_until(lambda: sub.get_num_connections() > 0, 15.0, 'the kit mending the subscription',
                        min_wall_s=15.0)
        self.wait_until(lambda: any(msg.data == 'mended' for msg in got), 10.0,
                        'a message through the mended subscription', min_wall_s=10.0)
        self.assertIn(TOPIC, [topic for topic, _ in OffboardTestCase.mender.mended])
        sub.unregister()


if __name__ == '__main__':
    rospy.init_node('test_kit_subscriptions')
    rostest.rosrun(PKG, 'kit_subscriptions', KitSubscriptionTest)
