#!/usr/bin/env python3
"""Signing end to end: the flight works signed, and unsigned frames aimed at either end
(a fake HEARTBEAT saying "landed, disarmed" to the bridge, a forced disarm to the vehicle,
an unsigned RADIO_STATUS to pull the bridge's link away) change nothing and are counted."""

import socket

import rospy
import rostest

from offboard_py import px4_modes
from offboard_py.dialect import ARM_DISARM_FORCE_MAGIC, mavlink
from offboard_py.testing.rostest_common import OffboardTestCase, RosoutRecorder, Vehicle, now

PKG = 'offboard_py'


class SignedLinkTest(OffboardTestCase):

    def test_signed_flight_and_spoofing_rejected(self):
        vehicle = Vehicle('mavros')
        bridge_log = RosoutRecorder('/mavros')
        self.wait_for_connected(vehicle, 30.0)
        self.wait_for_offboard_and_armed(vehicle, 60.0, 'OFFBOARD and armed over a signed link')
        self.wait_for_altitude(vehicle, 2.0, 0.15, 30.0)

        target = rospy.get_param('~target_system')
        bridge = ('127.0.0.1', rospy.get_param('~bridge_port'))
        fcu = ('127.0.0.1', rospy.get_param('~fcu_port'))
        spoof = mavlink.MAVLink(None, srcSystem=target, srcComponent=1)  # pretends to be the vehicle
        gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        land = px4_modes.encode('AUTO.LAND')
        landed_disarmed = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        start = now()
        for _ in range(40):
            sock.sendto(spoof.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, landed_disarmed,
                                               land, mavlink.MAV_STATE_STANDBY).pack(spoof), bridge)
            sock.sendto(spoof.radio_status_encode(200, 190, 0, 100, 90, 0, 0).pack(spoof), bridge)
            sock.sendto(gcs.command_long_encode(target, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                                0, ARM_DISARM_FORCE_MAGIC, 0, 0, 0, 0, 0).pack(gcs), fcu)
            sock.sendto(gcs.set_mode_encode(target, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, land).pack(gcs), fcu)
            self.pause(0.05)
        self.pause(1.0)
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
