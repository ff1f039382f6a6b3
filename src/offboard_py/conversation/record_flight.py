"""Recording the conversation of one takeoff flight on our stack, for rostest scenarios.

The flight of the references (reference/conversations/README.md): the tutorial's node connects,
streams setpoints, switches to OFFBOARD, arms and climbs; 30 s after the pose first reads
z >= 1.9 m the node is stopped (its setpoints end: PX4's offboard-loss failsafe), and the recording
runs 100 s more (AUTO.RTL, landing, disarm). The link is recorded by the relay between the bridge and
the simulator (offboard_py.testing.lossy_relay --record, no loss), stamped on the simulated clock,
so the recording's seconds compare with the reference's at any OFFBOARD_PY_SPEED.
Needs rospy and a node (rospy.init_node) in the caller.
"""

import socket

import rosnode

from offboard_py.testing.rostest_common import now

CLIMB_Z_M = 1.9          # the references' node stopped 30 s after the pose first read this
HOVER_AFTER_CLIMB_S = 30.0
RECORD_AFTER_STOP_S = 100.0
CONTROL_TIMEOUT_S = 5.0  # wall seconds for the relay to answer "flush"


def flush_relay(control_port, timeout_s=CONTROL_TIMEOUT_S):
    """Ask the relay on control_port to write out its recording; AssertionError if it does not say ok."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.settimeout(timeout_s)
        sock.sendto(b'flush', ('127.0.0.1', control_port))
        try:
            answer = sock.recv(200)
        except socket.timeout:
            raise AssertionError('the recording relay (control port %d) did not answer "flush" within %.0f s'
                                 % (control_port, timeout_s))
    finally:
        sock.close()
    if answer != b'ok':
        raise AssertionError('the recording relay refused "flush": %s' % answer.decode('ascii', 'replace'))


def fly_takeoff_and_record(case, vehicle, control_port, node='/offb_node_py', hover_s=HOVER_AFTER_CLIMB_S,
                           after_s=RECORD_AFTER_STOP_S, deadline_s=90.0):
    """Fly the references' flight with `case` (an OffboardTestCase) watching `vehicle` (a Vehicle), stop
    the node, wait, and have the relay write its recording out. Returns the ROS times of
    {'climbed', 'stopped'}."""
    case.wait_for_connected(vehicle, 30.0)
    case.wait_for_offboard_and_armed(vehicle, deadline_s)
    case.wait_until(lambda: vehicle.z() >= CLIMB_Z_M, 30.0,
                    'the pose at z >= %.1f m' % CLIMB_Z_M, [vehicle])
    climbed = now()
    case.pause(hover_s)
    rosnode.kill_nodes([node])
    stopped = now()
    case.pause(after_s)
    flush_relay(control_port)
    return {'climbed': climbed, 'stopped': stopped}
