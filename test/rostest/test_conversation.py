#!/usr/bin/env python3
"""Our stack's conversation on the FCU link, held to the real stack's.

The takeoff flight with the setpoints stopped (the offboard-loss failsafe) flown on our stack
(simulator + our bridge + offb_node) and recorded by a relay between the bridge and the simulator
(offboard_py.testing.conversation), then compared figure by figure (offboard_py.conversation) with
real mavros 1.21 + real PX4 SITL flying the same (reference/conversations/takeoff-mavros-px4): our
bridge's side (ros) against real mavros's, our simulator's side (fcu) against real PX4's. Every
difference fails the test unless ACCEPTED lists it, with its reason; an accepted difference that no
longer occurs fails it too, so the list only shrinks.
"""

import os

import rospkg
import rospy
import rostest

from offboard_py.conversation import analysis, compare, reading, report
from offboard_py.testing.conversation import fly_takeoff_and_record
from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle

PKG = 'offboard_py'
REFERENCE = 'reference/conversations/takeoff-mavros-px4.compact.jsonl.xz'

# fnmatch pattern of a figure's key (offboard_py.conversation.analysis) -> why we accept that it differs
ACCEPTED = {
}


class ConversationTest(OffboardTestCase):

    def test_conversation_as_the_real_stack(self):
        vehicle = Vehicle('mavros')
        fly_takeoff_and_record(self, vehicle, rospy.get_param('~control_port'),
                               after_s=rospy.get_param('~after_s', 100.0))
        path = rospy.get_param('~record')
        reference = analysis.Summary(reading.read(os.path.join(rospkg.RosPack().get_path(PKG), REFERENCE)),
                                     'real mavros + real PX4')
        ours = analysis.Summary(reading.read(path), 'our bridge + our simulator')
        differences = compare.compare(reference, ours)
        left, accepted, unused = compare.split_accepted(differences, ACCEPTED)
        lines = report.phase_table([reference, ours]) + [''] + report.difference_table(
            left, accepted, title='differences of our stack from real mavros + real PX4 (%s)' % path)
        text = '\n'.join(lines)
        print(text)
        if rospy.get_param('~report', ''):
            with open(rospy.get_param('~report'), 'w') as f:
                f.write(text + '\n')
        if rospy.get_param('~png', ''):
            report.plot([reference, ours], rospy.get_param('~png'))
        self.assertEqual(left, [], 'differences from the real stack that are not accepted:\n%s'
                         % '\n'.join(str(d) for d in left))
        self.assertEqual(unused, [], 'accepted differences that no longer occur (take them off ACCEPTED): %s'
                         % unused)


if __name__ == '__main__':
    rospy.init_node('test_conversation')
    rostest.rosrun(PKG, 'conversation', ConversationTest)
