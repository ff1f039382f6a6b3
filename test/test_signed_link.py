#!/usr/bin/env python3
"""Signing end to end: the flight works signed, and unsigned frames aimed at either end
(a fake HEARTBEAT saying "landed, disarmed" to the bridge, a forced disarm to the vehicle,
an unsigned RADIO_STATUS to pull the bridge's link away) change nothing and are counted."""

import socket
import time

import rospy
import rostest
from pymavlink.dialects.v20 import development as mavlink

from offboard_py import px4_modes
from offboard_test_common import OffboardTestCase, RosoutRecorder, Vehicle

PKG = 'offboard_py'
FORCE_DISARM = 21196.0


class SignedLinkTest(OffboardTestCase):

    def test_signed_flight_and_spoofing_rejected(self):
        vehicle = Vehicle('mavros')
        bridge_log = RosoutRecorder('/mavros')
        self.wait_for_connected(vehicle, 30.0)
        self.wait_until(lambda: vehicle.state.mode == 'OFFBOARD' and vehicle.state.armed, 60.0,
                        'OFFBOARD and armed over a signed link', [vehicle])
        self.wait_for_altitude(vehicle, 2.0, 0.15, 30.0)

        target = rospy.get_param('~target_system')
        bridge = ('127.0.0.1', rospy.get_param('~bridge_port'))
        fcu = ('127.0.0.1', rospy.get_param('~fcu_port'))
        spoof = mavlink.MAVLink(None, srcSystem=target, srcComponent=1)  # pretends to be the vehicle
        gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        land = px4_modes.encode('AUTO.LAND')
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        start = time.monotonic()
        for _ in range(40):
            sock.sendto(spoof.heartbeat_encode(2, 12, 1 | 16, land, 3).pack(spoof), bridge)  # MAV_TYPE_QUADROTOR
            sock.sendto(spoof.radio_status_encode(200, 190, 0, 100, 90, 0, 0).pack(spoof), bridge)
            sock.sendto(gcs.command_long_encode(target, 1, 400, 0, 0, FORCE_DISARM, 0, 0, 0, 0, 0).pack(gcs), fcu)
            sock.sendto(gcs.set_mode_encode(target, 1, land).pack(gcs), fcu)
            time.sleep(0.05)
        time.sleep(1.0)
        with vehicle.lock:
            after = [s for t, s in vehicle.states if t >= start]
        self.assertTrue(after, 'no state published during the spoofing')
        self.assertTrue(all(s.armed and s.mode == 'OFFBOARD' and s.connected for s in after),
                        'the spoofed frames changed the state: %s' % sorted({(s.mode, s.armed) for s in after}))
        self.assert_holds(vehicle, 2.0, 0.15, 2.0)  # the bridge still sends its setpoints to the vehicle
        rejected = [line for line in bridge_log.lines if line.startswith('signing: rejected an unsigned HEARTBEAT')]
        self.assertTrue(rejected, 'the bridge did not report the unsigned frames: %s' % bridge_log.lines[-5:])


if __name__ == '__main__':
    rospy.init_node('test_signed_link')
    rostest.rosrun(PKG, 'signed_link', SignedLinkTest)
