#!/usr/bin/env python3
"""Link cuts in hover, through the relay's control port. What PX4 and mavros do:
- setpoints cut (telemetry flowing): the vehicle leaves OFFBOARD COM_OF_LOSS_T after the
  last setpoint (seen on the next HEARTBEAT, so up to 1 s later); when they are back it flies OFFBOARD again
  (by itself, as PX4 does: reference/px4-sitl-offboard-regain.json, or because the node asked);
- both ways for 2 s, well under conn/timeout: the bridge stays connected throughout. The HEARTBEATs around
  the cut are up to cut + one period (3 s) apart; conn/timeout is 6 s here so that a scheduling stall of the
  simulator or relay (0.2 s of wall time is 1 s of simulated time at 5x) is not read as a lost link;
- both ways for LONG_CUT_S, over conn/timeout: the bridge reports disconnected conn/timeout after the
  last HEARTBEAT, then connected when the link is back; the vehicle landed and disarmed meanwhile.
Each time the vehicle returns to 2 m in OFFBOARD (the node re-arming it after the long cut).
"""

import socket

import rospy
import rostest

from offboard_py.testing.reference import px4_rate_hz
from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle, now

PKG = 'offboard_py'
HEARTBEAT_PERIOD_S = 1.0 / px4_rate_hz('HEARTBEAT')  # reference/px4-sitl-census.json
# long enough for PX4 to fail safe and land from 2 m and disarm: COM_OF_LOSS_T 1 s, landing from
# 2.2 m 12.8 s (PX4 SITL, px4-sitl-measured.md), COM_DISARM_LAND 2 s
LONG_CUT_S = 20.0
SETPOINT_CUT_S = 3.0


class LinkCutTest(OffboardTestCase):

    def cut(self, seconds, direction='both'):
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.settimeout(2.0)
        sock.sendto(('cut %g %s' % (seconds, direction)).encode(), ('127.0.0.1', rospy.get_param('~control_port')))
        try:
            reply = sock.recv(100)
        except socket.timeout:
            self.fail('the relay did not answer on its control port within 2 s')
        self.assertEqual(reply, b'ok')
        return now()

    def test_cuts_in_hover(self):
        vehicle = Vehicle('mavros')
        node_log = RosoutRecorder('/offb_node_py')
        loss_s = rospy.get_param('~offboard_loss_timeout')
        conn_timeout_s = rospy.get_param('~conn_timeout')
        self.wait_for_connected(vehicle, 30.0)
        self.wait_back_at_2m(vehicle, 'start-up', 60.0)

        # 1. setpoints cut for 3 s: failsafe after COM_OF_LOSS_T, then back to OFFBOARD (by itself, as PX4 does,
        #    or asked by the node); 3 s so that the failsafe lasts two HEARTBEAT periods and is seen
        start = self.cut(SETPOINT_CUT_S, 'to_fcu')
        self.wait_until(lambda: vehicle.state.mode != 'OFFBOARD', loss_s + HEARTBEAT_PERIOD_S + 2.0,
                        'leaving OFFBOARD without setpoints', [vehicle])
        left = next(s.header.stamp.to_sec() for t, s in vehicle.states_since(start) if s.mode != 'OFFBOARD')
        self.assertGreaterEqual(left - start, loss_s - 0.05, 'failsafe before COM_OF_LOSS_T')
        self.assertLessEqual(left - start, loss_s + HEARTBEAT_PERIOD_S + 1.0 + self.late_s(), 'failsafe late')
        self.assertIn(vehicle.state.mode, ('AUTO.RTL', 'AUTO.LAND', 'AUTO.LOITER'))
        rospy.loginfo('setpoints cut: %s after %.2f s', vehicle.state.mode, left - start)
        self.assertTrue(all(s.connected for _, s in vehicle.states_since(start)))
        self.wait_back_at_2m(vehicle, 'a %.0f s setpoint cut' % SETPOINT_CUT_S, 40.0)

        # 2. both ways for 2 s, shorter than conn/timeout: never reported disconnected
        self.pause(3.0)
        start = self.cut(2.0)
        # until the first HEARTBEAT after the cut (up to a period after it), however late this process reads it
        self.wait_until(lambda: any(s.header.stamp.to_sec() > start + 2.0 for _, s in vehicle.states_since(start)),
                        2.0 + HEARTBEAT_PERIOD_S + 3.0, 'a state after the 2 s cut', [vehicle])
        seen = vehicle.states_since(start)
        self.assertTrue(all(s.connected for _, s in seen), 'disconnected by a 2 s cut (conn/timeout %.0f s)'
                        % conn_timeout_s)
        self.wait_back_at_2m(vehicle, 'a 2 s cut both ways', 40.0)

        # 3. both ways for LONG_CUT_S: disconnected after conn/timeout, the vehicle lands and disarms;
        #    when the link is back the node re-arms it and it climbs to 2 m again
        self.pause(3.0)
        # both instants on the bridge's clock (the stamps of its State messages), not when the test read them
        with vehicle.lock:
            last_heartbeat = vehicle.states[-1][1].header.stamp.to_sec()
        start = self.cut(LONG_CUT_S)
        self.wait_until(lambda: not vehicle.state.connected, conn_timeout_s + 2.0, 'disconnected', [vehicle])
        lost = next(s.header.stamp.to_sec() for t, s in vehicle.states_since(start) if not s.connected)
        self.assertGreaterEqual(lost - last_heartbeat, conn_timeout_s - 0.1, 'disconnected before conn/timeout')
        self.assertLessEqual(lost - last_heartbeat, conn_timeout_s + 1.0 + self.late_s(), 'disconnected late')
        self.assertFalse(vehicle.state.armed or vehicle.state.mode, 'state not reset on disconnection: %s'
                         % vehicle.describe())
        rospy.loginfo('%.0f s cut: disconnected %.2f s after the last heartbeat', LONG_CUT_S, lost - last_heartbeat)
        self.wait_until(lambda: vehicle.state.connected, LONG_CUT_S + 3.0, 'connected again', [vehicle])
        # the first connected state after the loss, by the bridge's stamps (not the last one from before the cut)
        back = next(s for t, s in vehicle.states_stamped_since(lost) if s.connected)
        self.assertFalse(back.armed, 'the vehicle should have landed and disarmed during the %.0f s cut: %s'
                         % (LONG_CUT_S, back))
        arms_before = node_log.count('Vehicle armed')
        self.wait_back_at_2m(vehicle, 'a %.0f s cut both ways' % LONG_CUT_S, 40.0)
        self.assertGreater(node_log.count('Vehicle armed'), arms_before, 'the node did not re-arm the vehicle')
        # PX4 creeps over the last decimetre to 2 m (hover wander +-0.1 m): hold once within 0.1 m
        self.wait_for_altitude(vehicle, 2.0, 0.1, 30.0)
        self.assert_holds(vehicle, 2.0, 0.2, 2.0)


if __name__ == '__main__':
    rospy.init_node('test_link_cut')
    rostest.rosrun(PKG, 'link_cut', LinkCutTest)
