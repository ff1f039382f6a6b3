#!/usr/bin/env python3
"""Our stack's conversation on the FCU link, held to the real stack's.

The takeoff flight with the setpoints stopped (the offboard-loss failsafe) flown on our stack
(simulator + our bridge + offb_node) and recorded by a relay between the bridge and the simulator
(offboard_py.conversation.record_flight), then compared figure by figure (offboard_py.conversation) with
real mavros 1.21 + real PX4 SITL flying the same (reference/conversations/takeoff-mavros-px4): our
bridge's side (ros) against real mavros's, our simulator's side (fcu) against real PX4's. Every
difference fails the test unless ACCEPTED lists it, with its reason; an accepted difference that no
longer occurs fails it too, so the list only shrinks.
"""

import os

import rospkg
import rospy
import rostest

from offboard_py.conversation import analysis, compare, phases, reading, report
from offboard_py.conversation.record_flight import fly_takeoff_and_record
from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle

PKG = 'offboard_py'
REFERENCE = 'reference/conversations/takeoff-mavros-px4.compact.jsonl.xz'

BOOT = ('PX4 starts its streams over its first seconds after boot (its first HEARTBEAT 1.0 s after its '
        'first message, ATTITUDE 0.14 s and GLOBAL_POSITION_INT 1.26 s after that, HOME_POSITION once home is '
        'set); the simulator starts every stream, HEARTBEAT included, at boot and sets home when the pre-flight '
        'checks pass (4 s)')
HEARTBEAT_PHASE = ('PX4 says a mode or arming change in its next 1 Hz HEARTBEAT, strictly periodic in the '
                   'recording: the delay is that HEARTBEAT\'s phase against the request (0.04 s in the reference '
                   'by chance, 0-1 s here), and the phases it bounds move with it')

# fnmatch pattern of a figure's key (offboard_py.conversation.analysis) -> why we accept that it differs.
# Each must differ in every run: one that no longer does fails the test, so the list only shrinks.
ACCEPTED = {
    'phase/connecting/duration': BOOT,
    'first/fcu/*/after connected': BOOT,
    'rate/fcu/pre-stream/GLOBAL_POSITION_INT': BOOT,
    'first/ros/*/after connected': 'the FCU\'s first HEARTBEAT is the anchor: ours comes at its boot, with the '
                                   'bridge already up for 6 s, PX4\'s 1.0 s after its boot',
    'rate/fcu/*/UNKNOWN_41[01]': 'PX4\'s events interface (EVENT 410, CURRENT_EVENT_SEQUENCE 411) is not '
                                 'simulated: pymavlink 2.4.49 and our dialect lack both messages',
    'seq/fcu/comp 1/gaps per 1000': 'the reference\'s capture lost 0.05 % of PX4\'s frames on loopback; our '
                                    'relay records every frame it is given',
    'landed_state/fcu/4 #1/after last setpoint': 'PX4\'s failsafe return from 2 m over home holds about 3 s '
                                                 'before it descends (LANDING 4.1 s after the last setpoint); '
                                                 'ours descends at once (about 1.1 s)',
}
# Differences that come and go from run to run, with their reason: accepted, but not required.
MAY_DIFFER = {
    'rate/fcu/pre-stream/HOME_POSITION': BOOT + ' (0.5 Hz: a message more or less in the phase)',
    'rate/fcu/landed/TIME_ESTIMATE_TO_TARGET': '0.5 Hz over the 28 s landed phase: 13 messages in the reference '
                                               '(PX4\'s clock at 0.99 x), 14 or 15 here as the touchdown\'s moment '
                                               'moves the phase\'s start: a message more or less on each side',
    'rate/*/connecting/*': 'the connecting phase lasts 0.01-0.07 s here (the node\'s first setpoint follows our '
                           'first HEARTBEAT at once): its rates are counts over next to nothing',
    'phase/pre-stream/duration': HEARTBEAT_PHASE,
    'phase/OFFBOARD/duration': HEARTBEAT_PHASE,
    'mode/fcu/* shown after': HEARTBEAT_PHASE,
    'mode/fcu/*/after *': HEARTBEAT_PHASE,
    'rate/fcu/*/PARAM_VALUE': 'the parameter pull (10 s after the connection) falls across the pre-stream and '
                              'OFFBOARD boundary in the reference, which moves with the HEARTBEAT\'s phase',
    'rate/*/OFFBOARD/MISSION_*': 'the mission pulls (15 s after the connection) come 0.15 s before the arming '
                                 'shows in the reference: ' + HEARTBEAT_PHASE,
    'rate/*/armed hover/MISSION_*': 'the mission pulls (15 s after the connection) come 0.15 s before the '
                                    'arming shows in the reference: ' + HEARTBEAT_PHASE,
    'phase/landed/duration': 'the recording\'s length: the test waits on ROS time (/clock), which can trail '
                             'the relay\'s stamps on a loaded machine',
    'seq/*/messages': 'counts over the recording\'s length (phase/landed/duration)',
    'rate/fcu/landed/POSITION_TARGET_GLOBAL_INT': 'sent while the return lands and until the disarm: its rate over '
                                                  'the landed phase moves with the touchdown\'s moment',
}


class ConversationTest(OffboardTestCase):
    maxDiff = None  # every difference in the failure message

    def test_conversation_as_the_real_stack(self):
        vehicle = Vehicle('mavros')
        after_s = rospy.get_param('~after_s', 100.0)
        fly_takeoff_and_record(self, vehicle, rospy.get_param('~control_port'), after_s=after_s)
        path = rospy.get_param('~record')
        real = reading.read(os.path.join(rospkg.RosPack().get_path(PKG), REFERENCE))
        # the reference over the same window as ours: up to after_s past its last setpoint (it ran 100 s)
        end = phases.anchors(real)['last setpoint'] + after_s
        reference = analysis.Summary([m for m in real if m.t <= end], 'real mavros + real PX4')
        ours = analysis.Summary(reading.read(path), 'our bridge + our simulator')
        differences = compare.compare(reference, ours)
        left, accepted, unused = compare.split_accepted(differences, dict(MAY_DIFFER, **ACCEPTED))
        unused = [pattern for pattern in unused if pattern in ACCEPTED]
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
