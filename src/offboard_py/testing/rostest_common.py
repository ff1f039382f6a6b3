"""The base class of the rostest scenarios, in the manner of PX4's MavrosTestCommon.

`Vehicle` owns the subscriptions and service proxies of one vehicle namespace (`mavros`,
`uav1/mavros`, ...) and keeps what it saw; `OffboardTestCase` offers waits with deadlines
that fail with what was seen (mode, armed, position) rather than a bare assert, and
service calls bounded in time. Needs rospy and a node (rospy.init_node) in the caller.
"""

import threading
import time
import unittest

import rospy
from geometry_msgs.msg import PoseStamped, TwistStamped
from mavros_msgs.msg import ExtendedState, State
from mavros_msgs.srv import CommandBool, SetMode
from rosgraph_msgs.msg import Log

from offboard_py import frames


class Vehicle:
    """The mavros view of one vehicle."""

    def __init__(self, ns='mavros'):
        self.ns = ns.rstrip('/')
        self.lock = threading.Lock()
        self.state = State()
        self.extended_state = ExtendedState()
        self.pose = None
        self.velocity = None
        self.states = []      # (time, State) history
        self.poses = []       # (time, z ENU)
        self.velocities = []  # (time, vz ENU)
        self.setpoints = []   # times of the setpoints the node under test sent on setpoint_position/local
        self.subs = [
            rospy.Subscriber(self.ns + '/setpoint_position/local', PoseStamped, self._on_setpoint),
            rospy.Subscriber(self.ns + '/state', State, self._on_state),
            rospy.Subscriber(self.ns + '/extended_state', ExtendedState, self._on_extended),
            rospy.Subscriber(self.ns + '/local_position/pose', PoseStamped, self._on_pose),
            rospy.Subscriber(self.ns + '/local_position/velocity_local', TwistStamped, self._on_velocity),
        ]
        self.set_mode_srv = rospy.ServiceProxy(self.ns + '/set_mode', SetMode)
        self.arming_srv = rospy.ServiceProxy(self.ns + '/cmd/arming', CommandBool)

    def _on_state(self, msg):
        with self.lock:
            self.state = msg
            self.states.append((time.monotonic(), msg))

    def _on_setpoint(self, _msg):
        self.setpoints.append(time.monotonic())

    def _on_extended(self, msg):
        self.extended_state = msg

    def _on_pose(self, msg):
        with self.lock:
            self.pose = msg
            self.poses.append((time.monotonic(), msg.pose.position.z))

    def _on_velocity(self, msg):
        with self.lock:
            self.velocity = msg
            self.velocities.append((time.monotonic(), msg.twist.linear.z))

    def states_since(self, start):
        """(time, State) received at or after monotonic time `start`."""
        with self.lock:
            return [(t, s) for t, s in self.states if t >= start]

    def offboard_and_armed(self):
        return self.state.mode == 'OFFBOARD' and self.state.armed

    def describe(self):
        s = self.state
        text = '%s: %s, mode %r, %s' % (self.ns, 'connected' if s.connected else 'not connected', s.mode,
                                        'armed' if s.armed else 'disarmed')
        if self.pose is not None:
            p = self.pose.pose.position
            text += ', ENU (%.2f, %.2f, %.2f)' % (p.x, p.y, p.z)
        return text

    def z(self):
        return self.pose.pose.position.z if self.pose is not None else float('nan')


class OffboardTestCase(unittest.TestCase):
    """Waits with deadlines and messages that say what was seen."""

    def wait_until(self, predicate, timeout_s, what, vehicles=()):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if predicate():
                return True
            time.sleep(0.05)
        seen = '; '.join(v.describe() for v in vehicles) or 'nothing'
        self.fail('%s did not happen within %.0f s. Seen: %s' % (what, timeout_s, seen))

    def wait_for_connected(self, vehicle, timeout_s):
        self.wait_until(lambda: vehicle.state.connected, timeout_s, 'FCU connection', [vehicle])

    def wait_for_mode(self, vehicle, mode, timeout_s):
        self.wait_until(lambda: vehicle.state.mode == mode, timeout_s, 'mode %s' % mode, [vehicle])

    def wait_for_armed(self, vehicle, armed, timeout_s):
        self.wait_until(lambda: vehicle.state.armed == armed, timeout_s, 'armed' if armed else 'disarm', [vehicle])

    def wait_for_offboard_and_armed(self, vehicles, timeout_s, what='OFFBOARD and armed'):
        """Every one of vehicles (a Vehicle or a list) in OFFBOARD and armed at once."""
        vehicles = vehicles if isinstance(vehicles, (list, tuple)) else [vehicles]
        self.wait_until(lambda: all(v.offboard_and_armed() for v in vehicles), timeout_s, what, vehicles)

    def wait_for_altitude(self, vehicle, z_m, tolerance_m, timeout_s):
        self.wait_until(lambda: abs(vehicle.z() - z_m) <= tolerance_m, timeout_s,
                        'altitude %.2f +- %.2f m' % (z_m, tolerance_m), [vehicle])

    def wait_back_at_2m(self, vehicle, what, timeout_s=60.0, tolerance_m=0.2):
        """OFFBOARD and armed again after `what` within timeout_s, then at 2 m within 30 s."""
        self.wait_for_offboard_and_armed(vehicle, timeout_s, 'OFFBOARD and armed again after %s' % what)
        self.wait_for_altitude(vehicle, 2.0, tolerance_m, 30.0)

    def assert_holds(self, vehicle, z_m, tolerance_m, duration_s):
        """Every pose for duration_s stays within tolerance of z_m."""
        start = time.monotonic()
        time.sleep(duration_s)
        with vehicle.lock:
            samples = [z for t, z in vehicle.poses if t >= start]
        self.assertGreater(len(samples), duration_s * 10, 'too few poses (%d) in %.0f s' % (len(samples), duration_s))
        worst = max(samples, key=lambda z: abs(z - z_m))
        self.assertLessEqual(abs(worst - z_m), tolerance_m,
                             'did not hold %.2f +- %.2f m for %.0f s: reached %.3f m (%s)'
                             % (z_m, tolerance_m, duration_s, worst, vehicle.describe()))

    def call_service(self, proxy, timeout_s, **request):
        """proxy(**request), failing with the service's name when it is not there, or has not
        answered, within timeout_s in all. A rospy.ServiceException from the call is raised."""
        deadline = time.monotonic() + timeout_s
        try:
            proxy.wait_for_service(timeout_s)
        except rospy.ROSException:
            self.fail('service %s not available within %.1f s' % (proxy.resolved_name, timeout_s))
        outcome = []

        def call():
            try:
                outcome.append((True, proxy(**request)))
            except Exception as err:  # handed to the test's thread below
                outcome.append((False, err))
        worker = threading.Thread(target=call, daemon=True)
        worker.start()
        worker.join(max(0.0, deadline - time.monotonic()))
        if not outcome:
            self.fail('service %s%r did not answer within %.1f s' % (proxy.resolved_name, request, timeout_s))
        ok, value = outcome[0]
        if not ok:
            raise value
        return value

    def set_mode(self, vehicle, mode, timeout_s=10.0):
        """mode_sent of set_mode(custom_mode=mode)."""
        return self.call_service(vehicle.set_mode_srv, timeout_s, base_mode=0, custom_mode=mode).mode_sent

    def set_arm(self, vehicle, arm, timeout_s=10.0):
        """The response of cmd/arming(value=arm)."""
        return self.call_service(vehicle.arming_srv, timeout_s, value=arm)


class RosoutRecorder:
    """Collects what a node logged (from /rosout, which every rospy node publishes to)."""

    def __init__(self, node_name):
        self.node_name = node_name
        self.lines = []
        self.sub = rospy.Subscriber('/rosout', Log, self._on_log)

    def _on_log(self, msg):
        if msg.name == self.node_name:
            self.lines.append(msg.msg)

    def count(self, text):
        return sum(1 for line in self.lines if line == text)


def yaw_of(q):
    """Yaw (rad) of a geometry_msgs/Quaternion."""
    return frames.quaternion_yaw((q.x, q.y, q.z, q.w))
