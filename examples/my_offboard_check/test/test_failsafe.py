#!/usr/bin/env python3
"""PX4's low-battery failsafe under my node: the battery drained to 6 % in flight. PX4 holds (AUTO.LOITER) for
COM_FAIL_ACT_T, then returns (COM_LOW_BAT_ACT 3: Return at BAT_CRIT_THR 7 %) and lands; my node, which respects
the pilot, asks for OFFBOARD no more and keeps running."""
import rosnode
import rospy
import rostest
from offboard_py.testing import Failures, OffboardTestCase, RosoutRecorder, Vehicle, now


class LowBatteryTest(OffboardTestCase):

    def test_my_node_leaves_the_return_alone(self):
        vehicle = Vehicle('mavros')
        log = RosoutRecorder('/my_node')
        with Failures(rospy.get_param('~instance')) as px4:    # a ground station on the vehicle's GCS link
            self.wait_for_offboard_and_armed(vehicle, 60.0)
            self.wait_for_position(vehicle, (0.0, 0.0, 2.0), 30.0)
            start = now()
            px4.set_battery(6)                                 # drains to 6 % (PARAM_SET SIM_BAT_MIN_PCT)
            self.wait_for_mode(vehicle, 'AUTO.LOITER', 15.0)   # Hold for 5 s ...
            self.wait_for_mode(vehicle, 'AUTO.RTL', 10.0)      # ... then Return
            self.wait_for_armed(vehicle, False, 60.0)          # landed and disarmed
            self.assertIn('Failsafe activated', [text for _, _, text in px4.texts()])
        self.assertIn('/my_node', rosnode.get_node_names())   # my node is still running ...
        self.assertTrue(any(line.startswith('Pilot took over') for line in log.lines))  # ... it saw the failsafe
        armed_modes = [s.mode for _, s in vehicle.states_since(start) if s.armed]
        self.assertNotIn('OFFBOARD', armed_modes[armed_modes.index('AUTO.LOITER'):])  # ... and let it be


if __name__ == '__main__':
    rospy.init_node('test_failsafe')
    rostest.rosrun('my_offboard_check', 'failsafe', LowBatteryTest)
