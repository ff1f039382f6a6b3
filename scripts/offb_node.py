#!/usr/bin/env python3
"""The PX4 user guide's "ROS/MAVROS Offboard Example (Python)", as a node of this package.

It does what the tutorial does, in the tutorial's order: the mavros/state callback, the setpoint publisher,
the arming and set_mode clients, a setpoint stream at 20 Hz, a wait for the FCU connection, 100 setpoints,
then OFFBOARD and arming, requests 5 s apart, and the stream for as long as the node runs. The same names, the
same defaults. What it adds is marked "Added:" where it happens.

When to ask for what is offboard_py.offboard.OffboardLogic, the tutorial's if/else as a state machine,
tested offline (test/unit/test_offboard_logic.py). Where the vehicle should be is setpoint_at(t): change it to
fly a trajectory (scripts/offb_figure.py flies a figure of eight with its own).

    rosrun offboard_py offb_node.py [_x:=0 _y:=0 _z:=2 _yaw:=0 _rate:=20 _prestream_count:=100
                                     _request_interval:=5 _frame_id:= _respect_pilot:=false]
"""

import queue
import sys
import threading
import time

try:
    import rospy
    from geometry_msgs.msg import PoseStamped
    from mavros_msgs.msg import State
    from mavros_msgs.srv import CommandBool, SetMode

    from offboard_py import frames
    from offboard_py.master import await_master_from_argv
    from offboard_py.offboard import OFFBOARD, OffboardLogic, ParamError, Request, VehicleState, validate_config
except KeyboardInterrupt:  # Added: stopped while still importing (roslaunch shutting down): no traceback
    sys.exit(0)

NODE_NAME = 'offb_node_py'
WAIT_LOG_PERIOD_S = 5.0  # while waiting for the FCU, say so this often (wall s)
SHUTDOWN_CHECK_S = 1.0   # the main thread looks at rospy.is_shutdown() this often (wall s)


def setpoint_at(t, config):
    """Where the vehicle should be t seconds (ROS time) after the first setpoint: (x, y, z, yaw), ENU, m and
    rad. The tutorial's: a hover at (~x, ~y, ~z), 2 m up by default."""
    return config.x, config.y, config.z, config.yaw


class OffbNode:
    """The tutorial's node. Its main loop is two threads here: the stream (a rospy.Timer) publishes and sees
    when a request is due, the main thread makes the request (a service call may block for seconds)."""

    def __init__(self, config, setpoint_at=setpoint_at):
        self.config, self.setpoint_at = config, setpoint_at
        self.logic = OffboardLogic(config.prestream_count, config.request_interval_s, config.respect_pilot)
        self.lock = threading.Lock()             # the logic is shared by the state, stream and main threads
        self.connected = threading.Event()
        self.requests = queue.Queue(maxsize=1)   # the request the stream found due, for the main thread
        self.first_setpoint_s = None
        # The tutorial's subscriber, publisher and clients. Added: relative names, so a namespace
        # (<group ns="uav1">, ROS_NAMESPACE) moves the node together with its vehicle.
        self.state_sub = rospy.Subscriber('mavros/state', State, self.state_cb, queue_size=10)
        self.local_pos_pub = rospy.Publisher('mavros/setpoint_position/local', PoseStamped, queue_size=10)
        self.arming_client = rospy.ServiceProxy('mavros/cmd/arming', CommandBool)
        self.set_mode_client = rospy.ServiceProxy('mavros/set_mode', SetMode)
        rospy.on_shutdown(self.wake)

    def wake(self):
        """At shutdown: the main thread stops waiting at once."""
        self.connected.set()
        try:
            self.requests.put_nowait(None)
        except queue.Full:
            pass

    def state_cb(self, msg):
        with self.lock:
            lines = self.logic.on_state(VehicleState(msg.connected, msg.armed, msg.mode))
        if msg.connected:
            self.connected.set()
        for line in lines:  # Added: each transition logged once (FCU connected, OFFBOARD enabled, ...)
            rospy.loginfo(line)

    def stream(self, _event):
        """One setpoint; then, if a request is due, it goes to the main thread. Setpoint publishing MUST be
        faster than 2 Hz (PX4 leaves OFFBOARD after COM_OF_LOSS_T without them)."""
        with self.lock:
            if not self.logic.should_stream():  # from the FCU connection on, and then always
                return
        now = rospy.Time.now()
        if self.first_setpoint_s is None:
            self.first_setpoint_s = now.to_sec()
        x, y, z, yaw = self.setpoint_at(now.to_sec() - self.first_setpoint_s, self.config)
        pose = PoseStamped()
        pose.header.stamp, pose.header.frame_id = now, self.config.frame_id
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = x, y, z
        o = pose.pose.orientation
        o.x, o.y, o.z, o.w = frames.quaternion_from_yaw(yaw)
        try:
            self.local_pos_pub.publish(pose)
        except rospy.ROSException:
            if rospy.is_shutdown():
                return  # the timer fired while rospy closed the topic at shutdown
            raise
        with self.lock:
            self.logic.on_setpoint_sent(now.to_sec())  # the first prestream_count of them come before any request
            request = self.logic.take_request(now.to_sec())
        if request is not None:
            self.requests.put_nowait(request)  # one at a time: none other is taken until it is done

    def wait_for_connection(self):
        """Wait for Flight Controller connection. Added: saying so every WAIT_LOG_PERIOD_S."""
        start = time.monotonic()
        while not rospy.is_shutdown() and not self.connected.is_set():
            rospy.loginfo('Waiting for the FCU connection on %s (%.0f s so far)', self.state_sub.resolved_name,
                          time.monotonic() - start)
            self.connected.wait(WAIT_LOG_PERIOD_S)

    def call(self, request):
        """The tutorial's set_mode OFFBOARD or arming call. Added: a refusal or a failed call is logged, and
        the next request waits request_interval from its answer, whatever it was."""
        try:
            if request is Request.SET_OFFBOARD:
                if not self.set_mode_client(base_mode=0, custom_mode=OFFBOARD).mode_sent:
                    rospy.logwarn('%s answered mode_sent=false for OFFBOARD', self.set_mode_client.resolved_name)
            else:
                response = self.arming_client(value=True)
                if not response.success:
                    rospy.logwarn('Arming refused by the FCU (MAV_RESULT %d)', response.result)
        except rospy.ServiceException as err:
            if not rospy.is_shutdown():
                rospy.logwarn('%s failed: %s', request.value, err)
        finally:
            with self.lock:
                self.logic.on_request_done(rospy.get_time())

    def spin(self):
        # Added: the stream on its own thread, as the tutorial's tip says: a service call never stalls it
        timer = rospy.Timer(rospy.Duration(1.0 / self.config.rate_hz), self.stream)
        self.wait_for_connection()
        # The pre-stream (100 setpoints), then OFFBOARD, then arming, 5 s apart: each when the stream says
        while not rospy.is_shutdown():
            try:
                request = self.requests.get(timeout=SHUTDOWN_CHECK_S)
            except queue.Empty:
                continue
            if request is not None and not rospy.is_shutdown():
                self.call(request)
        timer.shutdown()


def main(setpoint_at=setpoint_at, node_name=NODE_NAME, read_params=None):
    """Run the node; return the process exit code (2 for a bad parameter). read_params(get): a setpoint_at's
    own parameters, read and checked (ParamError) with the node's."""
    # Added: a clear wait for the ROS master, bounded by _master_timeout:=SECONDS
    exit_code = await_master_from_argv(node_name)
    if exit_code is not None:
        return exit_code
    try:
        rospy.init_node(node_name)
        try:  # Added: every parameter checked, a bad one named (exit 2)
            config = validate_config(lambda name, default: rospy.get_param('~' + name, default))
            if read_params is not None:
                read_params(lambda name, default: rospy.get_param('~' + name, default))
        except ParamError as err:
            rospy.logfatal('%s', err)
            return 2
        if config.z <= 0.0:
            rospy.logwarn('~z is %g m: at or below the local origin (ENU, up; PX4 puts the origin where its '
                          'estimator started, on the ground). The vehicle will arm but not climb.', config.z)
        OffbNode(config, setpoint_at).spin()
    except (rospy.ROSInterruptException, KeyboardInterrupt):
        pass
    except rospy.ROSInitException as err:  # e.g. interrupted while rospy waited for the master
        print('%s: %s' % (node_name, err), file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
