"""rospy wiring of the tutorial's offboard node.

The decisions live in `offboard.OffboardLogic`; this module only connects them to
ROS: the mavros/state subscription, the setpoint publisher, the two service proxies.
Setpoints are published from their own rospy.Timer thread, so a service call that
blocks the main loop (mavros may take up to 5 s to answer cmd/arming) never stalls
the stream, as the tutorial's tip asks. The timer asks the logic after each setpoint,
as the tutorial's loop does, and wakes the main thread only when a request is due: a
main loop polling at 20 Hz beside the timer cost a fifth of the node's CPU in hover for
nothing. All names are relative, so a namespace (`<group ns="uav1">` or ROS_NAMESPACE)
moves the node together with its vehicle.
"""

import sys
import threading

import rospy
from geometry_msgs.msg import PoseStamped
from mavros_msgs.msg import State
from mavros_msgs.srv import CommandBool, SetMode

from offboard_py import frames
from offboard_py.master import await_master_from_argv
from offboard_py.offboard import OFFBOARD, OffboardLogic, ParamError, Request, VehicleState, validate_config

NODE_NAME = 'offb_node_py'
WAIT_LOG_PERIOD_S = 5.0
SHUTDOWN_CHECK_S = 1.0  # wall seconds between the main thread's looks at rospy.is_shutdown()


def make_setpoint(config):
    """The fixed PoseStamped the node streams (ENU position, unit quaternion from yaw)."""
    pose = PoseStamped()
    pose.header.frame_id = config.frame_id
    pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = config.x, config.y, config.z
    q = pose.pose.orientation
    q.x, q.y, q.z, q.w = frames.quaternion_from_yaw(config.yaw)
    return pose


class OffbNode:
    def __init__(self, config):
        self.config = config
        self.logic = OffboardLogic(config.prestream_count, config.request_interval_s, config.respect_pilot)
        self.lock = threading.Lock()  # the logic is shared by the state, timer and main threads
        self.request_due = threading.Event()  # set by the timer when the logic has a request to make
        self.start_s = None
        self.last_wait_log_s = None
        self.setpoint = make_setpoint(config)
        self.setpoint_pub = rospy.Publisher('mavros/setpoint_position/local', PoseStamped, queue_size=10)
        self.set_mode = rospy.ServiceProxy('mavros/set_mode', SetMode)
        self.arming = rospy.ServiceProxy('mavros/cmd/arming', CommandBool)
        self.state_sub = rospy.Subscriber('mavros/state', State, self._on_state, queue_size=10)
        rospy.on_shutdown(self.request_due.set)
        self.stream_timer = rospy.Timer(rospy.Duration(1.0 / config.rate_hz), self._stream)

    def _on_state(self, msg):
        with self.lock:
            lines = self.logic.on_state(VehicleState(msg.connected, msg.armed, msg.mode))
        for line in lines:
            rospy.loginfo(line)

    def _stream(self, _event):
        """One tick of the tutorial's loop: publish the setpoint, then see whether a request is due."""
        with self.lock:
            streaming = self.logic.should_stream()
        if not streaming:
            self._log_waiting(rospy.get_time())
            return
        self.setpoint.header.stamp = rospy.Time.now()
        try:
            self.setpoint_pub.publish(self.setpoint)
        except rospy.ROSException:
            if rospy.is_shutdown():
                return  # the timer fired while rospy closed the topic at shutdown
            raise
        now_s = rospy.get_time()
        with self.lock:
            self.logic.on_setpoint_sent(now_s)
            due = self.logic.next_request(now_s) is not None
        if due:
            self.request_due.set()

    def _log_waiting(self, now_s):
        if self.start_s is None:
            self.start_s = now_s
        if self.last_wait_log_s is None or now_s - self.last_wait_log_s >= WAIT_LOG_PERIOD_S:
            rospy.loginfo('Waiting for the FCU connection on %s (%.0f s so far)',
                          self.state_sub.resolved_name, now_s - self.start_s)
            self.last_wait_log_s = now_s

    def _request(self, request):
        try:
            if request is Request.SET_OFFBOARD:
                if not self.set_mode(base_mode=0, custom_mode=OFFBOARD).mode_sent:
                    rospy.logwarn('%s answered mode_sent=false for OFFBOARD', self.set_mode.resolved_name)
            else:
                response = self.arming(value=True)
                if not response.success:
                    rospy.logwarn('Arming refused by the FCU (MAV_RESULT %d)', response.result)
        except rospy.ServiceException as err:
            if not rospy.is_shutdown():
                rospy.logwarn('%s failed: %s', request.value, err)
        finally:
            with self.lock:
                self.logic.on_request_done(rospy.get_time())

    def spin(self):
        """Make the requests the timer finds due, one at a time, until shutdown."""
        while not rospy.is_shutdown():
            if not self.request_due.wait(SHUTDOWN_CHECK_S):
                continue
            self.request_due.clear()
            with self.lock:
                request = self.logic.next_request(rospy.get_time())
            if request is not None and not rospy.is_shutdown():
                self._request(request)


def main():
    """Run the node; return the process exit code (2 for a bad parameter)."""
    exit_code = await_master_from_argv(NODE_NAME)
    if exit_code is not None:
        return exit_code
    try:
        rospy.init_node(NODE_NAME)
        try:
            config = validate_config(lambda name, default: rospy.get_param('~' + name, default))
        except ParamError as err:
            rospy.logfatal('%s', err)
            return 2
        if config.z <= 0.0:
            rospy.logwarn('~z is %g m: at or below the local origin (ENU, up; PX4 puts the origin where its '
                          'estimator started, on the ground). The vehicle will arm but not climb.', config.z)
        OffbNode(config).spin()
    except (rospy.ROSInterruptException, KeyboardInterrupt):
        pass
    except rospy.ROSInitException as err:  # e.g. interrupted while rospy waited for the master
        print('%s: %s' % (NODE_NAME, err), file=sys.stderr)
        return 1
    return 0
