"""The test kit's mending of rospy's registration race (offboard_py.testing.subscriptions), on a clock of the
test's own: a subscription without a connection while the master lists publishers is handed the list again
after MEND_AFTER_WALL_S, and said; a connected one, or one nobody publishes, is left alone."""

import xmlrpc.client

from offboard_py.testing.subscriptions import LOOK_EVERY_WALL_S, MEND_AFTER_WALL_S, SubscriptionMender

from manual_clock import ManualClock


class Rig:
    def __init__(self):
        self.clock = ManualClock()
        self.subs = {'/mavros/state': 0, '/mavros/local_position/pose': 1, '/mavros/setpoint_raw/global': 0}
        self.publishers = {'/mavros/state': ['http://localhost:39967/'], '/mavros/local_position/pose':
                           ['http://localhost:39967/']}
        self.handed, self.said, self.asked = [], [], []
        self.mender = SubscriptionMender(
            clock=self.clock, subscriptions=lambda: [(t, 'x/Y', n) for t, n in self.subs.items()],
            master_publishers=self.master_publishers, hand_on=lambda t, uris: self.handed.append((t, uris)),
            say=self.said.append, own_uri=lambda: 'http://localhost:40001/')

    def master_publishers(self, topic, _type):
        self.asked.append(topic)
        return self.publishers.get(topic, [])

    def run_for(self, wall_s):
        end = self.clock.now_s + wall_s
        while self.clock.now_s < end:
            self.mender.look()
            self.clock.sleep(0.05)


def test_an_unconnected_subscription_is_handed_the_masters_list_once_it_has_waited():
    rig = Rig()
    rig.run_for(MEND_AFTER_WALL_S - 0.1)
    assert rig.handed == [], 'a connection normally comes within milliseconds: not before %.0f s' % MEND_AFTER_WALL_S
    rig.run_for(LOOK_EVERY_WALL_S + 0.2)
    assert rig.handed == [('/mavros/state', ['http://localhost:39967/'])]
    assert '/mavros/local_position/pose' not in rig.asked, 'a connected subscription is not asked about'
    assert any('/mavros/state' in line and 'http://localhost:39967/' in line for line in rig.said)
    assert rig.mender.mended == [('/mavros/state', ['http://localhost:39967/'])]


def test_a_topic_nobody_publishes_is_only_asked_about_and_a_connection_ends_it():
    rig = Rig()
    rig.run_for(MEND_AFTER_WALL_S + LOOK_EVERY_WALL_S + 0.2)
    assert ('/mavros/setpoint_raw/global', []) not in rig.handed and rig.said == ['the subscription to '
           '/mavros/state had no connection for 2 wall seconds while the master lists its publishers '
           'http://localhost:39967/: handed on again (rospy kept an older, empty list)']
    rig.run_for(2 * MEND_AFTER_WALL_S)  # still unconnected (a publisher killed stays listed): handed on, said once
    assert len(rig.handed) >= 2 and len(rig.said) == 1, (rig.handed, rig.said)
    rig.subs['/mavros/state'] = 1  # the mending worked
    handed = len(rig.handed)
    rig.run_for(3 * MEND_AFTER_WALL_S)
    assert len(rig.handed) == handed, 'a connected subscription is not handed on again'


def test_a_master_that_does_not_answer_is_said_with_the_topic():
    rig = Rig()

    def down(topic, _type):
        raise ConnectionRefusedError(111, 'Connection refused')

    rig.mender._master_publishers = down
    rig.run_for(MEND_AFTER_WALL_S + LOOK_EVERY_WALL_S + 0.2)
    assert rig.handed == [] and any('/mavros/state' in line and 'Connection refused' in line for line in rig.said)
    rig.mender._master_publishers = lambda t, _: (_ for _ in ()).throw(xmlrpc.client.Fault(1, 'bad'))
    rig.run_for(MEND_AFTER_WALL_S + LOOK_EVERY_WALL_S)
    assert any('bad' in line for line in rig.said)


def test_this_nodes_own_publications_are_not_handed_on():
    """A test node's own publisher (bridge.test publishes on the topics its Vehicle watches) is left to rospy."""
    rig = Rig()
    rig.publishers['/mavros/setpoint_raw/global'] = ['http://localhost:40001/']
    rig.run_for(MEND_AFTER_WALL_S + LOOK_EVERY_WALL_S + 0.2)
    assert [topic for topic, _ in rig.handed] == ['/mavros/state']
