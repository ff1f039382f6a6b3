#!/usr/bin/env python3
"""Offboard signal lost mid-hover: the vehicle leaves OFFBOARD within COM_OF_LOSS_T + 0.3 s for
PX4's failsafe (no RC: Return, which lands at once next to home), comes down under control,
lands and disarms."""

import socket
import threading
import time

import rosnode
import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from pymavlink.dialects.v20 import development as mavlink

from offboard_py import px4_modes
from offboard_test_common import OffboardTestCase, Vehicle

PKG = 'offboard_py'
COM_OF_LOSS_T = 0.5      # the simulator's default (the tutorial's figure)
LAND_SPEED = 0.7         # MPC_LAND_SPEED


class GcsListener:
    """Plays the ground station on the bridge's gcs_url: every FCU message, timestamped."""

    def __init__(self, port):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(('127.0.0.1', port))
        self.sock.settimeout(0.1)
        self.modes = []  # (time, mode) from CURRENT_MODE
        threading.Thread(target=self._rx, daemon=True).start()

    def _rx(self):
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        while True:
            try:
                data, _ = self.sock.recvfrom(4096)
            except socket.timeout:
                continue
            now = time.monotonic()
            for msg in parser.parse_buffer(data) or []:
                if msg.get_type() == 'CURRENT_MODE':
                    self.modes.append((now, px4_modes.decode(msg.custom_mode)))


class OffboardLossTest(OffboardTestCase):

    def test_failsafe_when_node_dies(self):
        gcs = GcsListener(14660)
        vehicle = Vehicle('mavros')
        setpoints = []
        rospy.Subscriber('mavros/setpoint_position/local', PoseStamped, lambda m: setpoints.append(time.monotonic()))
        self.wait_until(lambda: vehicle.state.mode == 'OFFBOARD' and vehicle.state.armed, 60.0,
                        'OFFBOARD and armed', [vehicle])
        self.wait_for_altitude(vehicle, 2.0, 0.15, 30.0)
        time.sleep(1.0)
        rosnode.kill_nodes(['/offb_node_py'])
        self.wait_until(lambda: any(m != 'OFFBOARD' for t, m in gcs.modes if setpoints and t > setpoints[-1]), 5.0,
                        'a mode change after the last setpoint', [vehicle])
        last = setpoints[-1]
        when, mode = next((t, m) for t, m in gcs.modes if t > last and m != 'OFFBOARD')
        self.assertEqual(mode, 'AUTO.RTL', 'no RC: PX4 applies NAV_RCL_ACT (Return)')
        self.assertLessEqual(when - last, COM_OF_LOSS_T + 0.3,
                             'left OFFBOARD %.2f s after the last setpoint' % (when - last))
        start = time.monotonic()
        self.wait_for_armed(vehicle, False, 30.0)
        with vehicle.lock:
            descent = [vz for t, vz in vehicle.velocities if t >= start]
        self.assertGreaterEqual(min(descent), -(LAND_SPEED + 0.3),
                                'came down at %.2f m/s (land speed %.1f)' % (-min(descent), LAND_SPEED))
        self.assertLess(vehicle.z(), 0.05, 'landed: %s' % vehicle.describe())
        self.assertEqual(vehicle.extended_state.landed_state, 1, 'ON_GROUND')


if __name__ == '__main__':
    rospy.init_node('test_offboard_loss')
    rostest.rosrun(PKG, 'offboard_loss', OffboardLossTest)
