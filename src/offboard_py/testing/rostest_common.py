"""The base class of the rostest scenarios, in the manner of PX4's MavrosTestCommon.

`Vehicle` owns the subscriptions and service proxies of one vehicle namespace (`mavros`,
`uav1/mavros`, ...) and keeps what it saw; `OffboardTestCase` offers waits with deadlines
that fail with what was seen (mode, armed, position) rather than a bare assert, and
service calls bounded in time. Needs rospy and a node (rospy.init_node) in the caller.

Every time here is ROS time (`now()`, `OffboardTestCase.pause`): in simulated time
(sim_clock.launch, /use_sim_time) deadlines and durations are simulated seconds, so a
scenario asserts the same bounds at every speed. The clock guard fails a scenario whose ROS
side has fallen behind the vehicles' clock (the machine cannot keep up at that speed) rather
than letting it report a failsafe that the lag, not the vehicle, caused.
"""

import collections
import math
import threading
import time
import unittest

import rospy
from geographic_msgs.msg import GeoPoseStamped
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from mavros_msgs.msg import AttitudeTarget, ExtendedState, GlobalPositionTarget, PositionTarget, State, Thrust
from mavros_msgs.srv import CommandBool, SetMode
from rosgraph_msgs.msg import Log

from offboard_py import frames, ros_participant
from offboard_py.testing.subscriptions import SubscriptionMender

CLOCK_START_TIMEOUT_S = 30.0  # wall seconds for the first /clock in simulated time
START_WALL_S = 15.0  # wall seconds a connection wait allows at least: nodes start in wall time
MAX_CLOCK_LAG_S = 0.5  # simulated seconds the ROS side may trail the vehicles (COM_OF_LOSS_T is 1 s)
CATCH_UP_WALL_S = 0.25  # wall seconds a lag over that may take to go (a stall of this process, not a backlog)
# Wall seconds a process of a scenario (the simulator, the bridge, this node) may wait for a CPU on a busy
# 2-core machine: CI's 5x run saw a Hold 1.25 simulated seconds past its bound (0.25 s of wall time)
BUSY_WALL_S = 0.5


def _sim_time():
    return rospy.get_param('/use_sim_time', False) is True


def now():
    """ROS time in seconds; in simulated time, waits (bounded) for the first /clock."""
    t = rospy.get_time()
    if t == 0.0 and _sim_time():
        deadline = time.monotonic() + CLOCK_START_TIMEOUT_S
        while t == 0.0 and time.monotonic() < deadline and not rospy.is_shutdown():
            time.sleep(0.01)
            t = rospy.get_time()
        if t == 0.0:
            raise AssertionError('no /clock within %.0f s although /use_sim_time is set: is sim_clock running?'
                                 % CLOCK_START_TIMEOUT_S)
    return t


class ClockGuard:
    """How far this node's ROS time trails the vehicles' clock (the run's governed clock, offboard_py.clock_board,
    or speed x the monotonic clock without one) in simulated time; 0 in real time. This node is a participant
    of the governed clock: the clock waits while it falls behind, so a lag over the bound means this node
    stopped keeping up for longer than the board's stale time."""

    def __init__(self):
        self.speed = float(rospy.get_param('/sim_clock/speed', 1.0)) if _sim_time() else 1.0
        self.worst_s = 0.0
        self.stalls = 0  # lags over MAX_CLOCK_LAG_S that went within CATCH_UP_WALL_S
        self.participant = ros_participant.join('test %s' % rospy.get_name()) if self.speed != 1.0 else None

    def vehicles_s(self):
        if self.participant is not None:
            return self.participant.board.now()
        return self.speed * time.monotonic()

    def holds(self):
        """(count, wall seconds, last holder) of the clock's waits for its slowest participant, or None."""
        return self.participant.board.holds() if self.participant is not None else None

    def lag_s(self):
        if self.speed == 1.0:
            return 0.0
        lag = self.vehicles_s() - now()
        self.worst_s = max(self.worst_s, lag)
        return lag

    def problem(self):
        """None, or why this run cannot be trusted at its speed.

        A lag read just after this process was off the CPU for a moment (its threads had no turn to take
        the /clock ticks meanwhile) goes as soon as they run: sim_clock ticks the vehicles' time, not a
        count. Only a lag that stays for CATCH_UP_WALL_S is the ROS side falling behind."""
        lag = self.lag_s()
        if lag <= MAX_CLOCK_LAG_S:
            return None
        stalled_at, deadline = time.monotonic(), time.monotonic() + CATCH_UP_WALL_S
        while time.monotonic() < deadline:
            time.sleep(0.01)
            if self.lag_s() <= MAX_CLOCK_LAG_S:
                self.stalls += 1
                rospy.logwarn('the ROS side was %.2f s (simulated) behind the vehicles\' clock at %gx and caught '
                              'up in %.3f s of wall time (a stall of this test node)',
                              lag, self.speed, time.monotonic() - stalled_at)
                return None
        return ('the ROS side is %.2f s (simulated) behind the vehicles\' clock at %gx and stayed behind for %.2f s '
                'of wall time: this machine cannot keep up at that speed, so what the scenario sees now is the '
                'machine\'s doing, not the vehicle\'s; run it slower (OFFBOARD_PY_SPEED=1 is real time)'
                % (self.lag_s(), self.speed, CATCH_UP_WALL_S))


# One setpoint the node under test sent: its ROS time of arrival, the mavros topic (relative to the vehicle's
# namespace) and what it sets, by field: 'position' (x, y, z; ENU, m, or the raw message's coordinate_frame),
# 'velocity' (x, y, z, m/s), 'acceleration' (x, y, z, m/s^2), 'yaw' (rad), 'yaw_rate' (rad/s), 'global'
# (latitude, longitude, altitude), 'attitude' (quaternion x, y, z, w), 'body_rate' (x, y, z, rad/s), 'thrust'
# (0..1), 'angular' (x, y, z, rad/s, of a Twist), 'frame' (the raw message's coordinate_frame). A raw message
# has only the fields its type_mask does not ignore.
Setpoint = collections.namedtuple('Setpoint', 't topic fields')

# PositionTarget / GlobalPositionTarget type_mask bits (mavros_msgs, as MAVLink's POSITION_TARGET_TYPEMASK)
_IGNORE_POSITION, _IGNORE_VELOCITY, _IGNORE_ACCELERATION = 0x7, 0x38, 0x1C0
_IGNORE_YAW, _IGNORE_YAW_RATE = 0x400, 0x800


def _xyz(v):
    return (v.x, v.y, v.z)


def _quaternion(q):
    return (q.x, q.y, q.z, q.w)


def _raw_fields(msg, position):
    """The fields a PositionTarget or GlobalPositionTarget sets, by its type_mask."""
    mask, fields = msg.type_mask, {'frame': msg.coordinate_frame}
    if not mask & _IGNORE_POSITION:
        fields.update(position)
    if not mask & _IGNORE_VELOCITY:
        fields['velocity'] = _xyz(msg.velocity)
    if not mask & _IGNORE_ACCELERATION:
        fields['acceleration'] = _xyz(msg.acceleration_or_force)
    if not mask & _IGNORE_YAW:
        fields['yaw'] = msg.yaw
    if not mask & _IGNORE_YAW_RATE:
        fields['yaw_rate'] = msg.yaw_rate
    return fields


def _attitude_target_fields(msg):
    fields = {}
    if not msg.type_mask & AttitudeTarget.IGNORE_ATTITUDE:
        fields['attitude'] = _quaternion(msg.orientation)
    if msg.type_mask & 0x7 != 0x7:
        fields['body_rate'] = _xyz(msg.body_rate)
    if not msg.type_mask & AttitudeTarget.IGNORE_THRUST:
        fields['thrust'] = msg.thrust
    return fields


# every setpoint topic of mavros 1.21 a node may send on: (topic, type, its fields)
SETPOINT_TOPICS = (
    ('setpoint_position/local', PoseStamped,
     lambda m: {'position': _xyz(m.pose.position), 'yaw': yaw_of(m.pose.orientation)}),
    ('setpoint_position/global', GeoPoseStamped,
     lambda m: {'global': (m.pose.position.latitude, m.pose.position.longitude, m.pose.position.altitude),
                'yaw': yaw_of(m.pose.orientation)}),
    ('setpoint_raw/local', PositionTarget, lambda m: _raw_fields(m, {'position': _xyz(m.position)})),
    ('setpoint_raw/global', GlobalPositionTarget,
     lambda m: _raw_fields(m, {'global': (m.latitude, m.longitude, m.altitude)})),
    ('setpoint_raw/attitude', AttitudeTarget, _attitude_target_fields),
    ('setpoint_velocity/cmd_vel', TwistStamped,
     lambda m: {'velocity': _xyz(m.twist.linear), 'angular': _xyz(m.twist.angular)}),
    ('setpoint_velocity/cmd_vel_unstamped', Twist, lambda m: {'velocity': _xyz(m.linear), 'angular': _xyz(m.angular)}),
    ('setpoint_attitude/attitude', PoseStamped, lambda m: {'attitude': _quaternion(m.pose.orientation)}),
    ('setpoint_attitude/cmd_vel', TwistStamped, lambda m: {'body_rate': _xyz(m.twist.angular)}),
    ('setpoint_attitude/thrust', Thrust, lambda m: {'thrust': m.thrust}),
)


class Vehicle:
    """The mavros view of one vehicle: what mavros says of it, and every setpoint sent to it.

    Histories (lists, appended as messages arrive; times are ROS times, simulated seconds in simulated time;
    read a copy under `lock` or with list(...)):
      states            (t, mavros_msgs/State)
      positions         (t, (x, y, z)) ENU, m, from local_position/pose
      poses             (t, z): the heights of `positions`
      velocities        (t, (vx, vy, vz)) ENU, m/s, from local_position/velocity_local
      setpoint_history  Setpoint(t, topic, fields) of every setpoint topic of mavros (SETPOINT_TOPICS)
      setpoints         t of each of them: when the node under test streamed last, whatever it sends
    """

    def __init__(self, ns='mavros'):
        self.ns = ns.rstrip('/')
        self.lock = threading.Lock()
        self.state = State()
        self.extended_state = ExtendedState()
        self.pose = None
        self.velocity = None
        self.states = []
        self.positions = []
        self.velocities = []
        self.setpoints = []
        self.setpoint_history = []
        self.subs = [
            rospy.Subscriber(self.ns + '/state', State, self._on_state),
            rospy.Subscriber(self.ns + '/extended_state', ExtendedState, self._on_extended),
            rospy.Subscriber(self.ns + '/local_position/pose', PoseStamped, self._on_pose),
            rospy.Subscriber(self.ns + '/local_position/velocity_local', TwistStamped, self._on_velocity),
        ] + [rospy.Subscriber(self.ns + '/' + topic, kind, self._on_setpoint, (topic, fields))
             for topic, kind, fields in SETPOINT_TOPICS]
        self.set_mode_srv = rospy.ServiceProxy(self.ns + '/set_mode', SetMode)
        self.arming_srv = rospy.ServiceProxy(self.ns + '/cmd/arming', CommandBool)

    def _on_setpoint(self, msg, topic_and_fields):
        topic, fields = topic_and_fields
        t = now()
        with self.lock:
            self.setpoints.append(t)
            self.setpoint_history.append(Setpoint(t, topic, fields(msg)))

    def setpoint_values(self, field, since=0.0):
        """(t, value) of every setpoint since ROS time `since` that sets `field` ('position', 'velocity', ...)."""
        with self.lock:
            return [(sp.t, sp.fields[field]) for sp in self.setpoint_history if sp.t >= since and field in sp.fields]

    def setpoint_counts(self):
        """{topic: how many setpoints arrived on it}, for the topics the node used."""
        with self.lock:
            return dict(collections.Counter(sp.topic for sp in self.setpoint_history))

    def _on_state(self, msg):
        with self.lock:
            self.state = msg
            self.states.append((now(), msg))

    def _on_extended(self, msg):
        self.extended_state = msg

    def _on_pose(self, msg):
        with self.lock:
            self.pose = msg
            p = msg.pose.position
            self.positions.append((now(), (p.x, p.y, p.z)))

    def _on_velocity(self, msg):
        with self.lock:
            self.velocity = msg
            self.velocities.append((now(), _xyz(msg.twist.linear)))

    def states_since(self, start):
        """(time, State) received at or after ROS time `start`."""
        with self.lock:
            return [(t, s) for t, s in self.states if t >= start]

    def states_stamped_since(self, start):
        """(time, State) stamped at or after ROS time `start` (the bridge's clock when the HEARTBEAT came): a busy
        test may read a state from before an event (a cut, the arming's answer) after it, and states_since has it."""
        with self.lock:
            return [(t, s) for t, s in self.states if t >= start and s.header.stamp.to_sec() >= start]

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

    @property
    def poses(self):
        """(time, z ENU) history: the heights of `positions` (a copy; safe with or without `lock` held)."""
        return [(t, p[2]) for t, p in list(self.positions)]

def _any_since(vehicle, history, accept, since=None):
    """A predicate for wait_until: has any (t, sample) of vehicle.<history> that came since now (or since ROS
    time `since`) met accept(sample)? Every sample is looked at, not only the newest at each look: what a
    vehicle passes through is there for a second or less, and a look that a busy machine delays by a tenth of a
    wall second is half a simulated second late at 5x."""
    with vehicle.lock:
        samples = getattr(vehicle, history)
        first = len(samples) if since is None else next((i for i, (t, _) in enumerate(samples) if t >= since),
                                                         len(samples))
        looked = [first]

    def predicate():
        with vehicle.lock:
            fresh = getattr(vehicle, history)[looked[0]:]
        looked[0] += len(fresh)
        return any(accept(sample) for _, sample in fresh)
    return predicate


def _reached(vehicle, accept):
    """Has any pose since now met accept(position)? (a corner the vehicle turns at, an overshoot through 2 m)"""
    return _any_since(vehicle, 'positions', accept)


def _seen(vehicle, accept, since=None):
    """Does the newest state, or any state since now, meet accept(state)? With `since` (ROS time): any state
    received since then, and only those. A mode a vehicle passes through (a Hold before the Return, the pilot's
    mode before a node takes OFFBOARD back) may be shown for a single 1 Hz HEARTBEAT, 0.2 wall seconds at 5x."""
    fresh = _any_since(vehicle, 'states', accept, since)  # first: a state that comes before the newest is read is in it
    if since is not None:
        return fresh
    with vehicle.lock:
        current = vehicle.state
    return (lambda: True) if accept(current) else fresh


def _closest(vehicle, start, distance, describe):
    """Where the vehicle came nearest (by distance(position)) since ROS time start, and when: a text."""
    with vehicle.lock:
        samples = [(t, p) for t, p in vehicle.positions if t >= start]
    if not samples:
        return 'no pose since the wait began'
    t, p = min(samples, key=lambda sample: distance(sample[1]))
    return 'ENU (%.2f, %.2f, %.2f) at %.1f s into the wait, %s' % (p + (t - start, describe(p)))


def _offset(position, target):
    """(horizontal, vertical) distance in metres between two (x, y, z)."""
    return math.hypot(position[0] - target[0], position[1] - target[1]), abs(position[2] - target[2])


class OffboardTestCase(unittest.TestCase):
    """Waits with deadlines (ROS time) and messages that say what was seen."""

    clock_guard = None
    mender = None  # SubscriptionMender, one for the process: guard() has it look at the subscriptions

    def _clock_guard(self):
        if self.clock_guard is None:
            OffboardTestCase.clock_guard = ClockGuard()
        return self.clock_guard

    @classmethod
    def tearDownClass(cls):
        guard = OffboardTestCase.clock_guard
        holds = guard.holds() if guard is not None else None
        if holds and holds[0]:
            rospy.loginfo('the governed clock waited %d times for its slowest participant, %.2f wall seconds in all '
                          '(the last for %s): this run took that much longer, and no deadline moved', *holds)

    def guard(self):
        """Fail now if the ROS side cannot keep up with the simulated clock; mend a subscription that rospy's
        registration race left without its publisher (offboard_py.testing.subscriptions)."""
        if OffboardTestCase.mender is None:
            OffboardTestCase.mender = SubscriptionMender()
        OffboardTestCase.mender.look()
        problem = self._clock_guard().problem()
        if problem:
            self.fail(problem)

    def late_s(self):
        """How much later (simulated s) than the vehicle made a change a busy machine may let this node see it:
        BUSY_WALL_S at the scenario's speed (at 5x a 0.1 s wait for a CPU is half a simulated second). The
        upper bounds of what a scenario times add it; the simulated PX4's own timing is held to the tenth
        offline on a clock of its own (test/unit/test_sim_failsafes.py) and beside real PX4's in bench/results."""
        return BUSY_WALL_S * self._clock_guard().speed

    def pause(self, duration_s):
        """Let duration_s of ROS time pass, watching the clock guard."""
        end = now() + duration_s
        while not rospy.is_shutdown():
            self.guard()
            left = end - now()
            if left <= 0:
                return
            rospy.sleep(min(left, 0.1))

    def wait_until(self, predicate, timeout_s, what, vehicles=(), min_wall_s=0.0, closest=None):
        """Until predicate() holds: at most timeout_s of ROS time, but never less than min_wall_s of
        wall time (for what processes do in wall time, such as starting up). On failure the message says
        what the vehicles were doing last and, with closest(start) (a text), how near the wait came."""
        start = now()
        deadline, wall_deadline = start + timeout_s, time.monotonic() + min_wall_s
        while (now() < deadline or time.monotonic() < wall_deadline) and not rospy.is_shutdown():
            if predicate():
                return True
            self.guard()
            rospy.sleep(0.05)
        self.guard()
        seen = '; '.join(v.describe() for v in vehicles) or 'nothing'
        nearest = ('. Closest: %s' % closest(start)) if closest is not None else ''
        self.fail('%s did not happen within %.0f s. Seen: %s%s' % (what, timeout_s, seen, nearest))

    def until_accepted(self, vehicle, what, ask, seen, timeout_s, state_period_s=1.0):
        """ask() (a service call, True when it says it was sent) until seen() holds within a state
        period (mavros's state follows the 1 Hz HEARTBEAT) and a second of a successful answer, at most
        timeout_s: PX4 refuses a mode or the arming until it is ready, and mavros's set_mode answers
        mode_sent without waiting for PX4's verdict, so the state says it. The time of the answer that took."""
        deadline = now() + timeout_s
        while now() < deadline:
            if ask():
                answered = now()
                while now() < answered + state_period_s + 1.0:
                    if seen():
                        return answered
                    self.pause(0.05)
            else:
                self.pause(1.0)
        self.fail('%s not accepted within %.0f s (%s)' % (what, timeout_s, vehicle.describe()))

    def wait_for_connected(self, vehicle, timeout_s):
        # processes start in wall time whatever the speed: at 100x, 30 simulated seconds are 0.3 wall seconds
        self.wait_until(lambda: vehicle.state.connected, timeout_s, 'FCU connection', [vehicle],
                        min_wall_s=START_WALL_S)

    def wait_for_mode(self, vehicle, mode, timeout_s, since=None):
        """The vehicle in `mode` now or in any state since the wait began (with `since`, a ROS time: in any
        state received since then, such as a command sent before the wait), within timeout_s (_seen)."""
        self.wait_until(_seen(vehicle, lambda s: s.mode == mode, since), timeout_s, 'mode %s' % mode, [vehicle])

    def wait_for_armed(self, vehicle, armed, timeout_s, since=None):
        """The vehicle armed (or disarmed) now or in any state since the wait began (or since `since`), within
        timeout_s (_seen)."""
        self.wait_until(_seen(vehicle, lambda s: s.armed == armed, since), timeout_s,
                        'armed' if armed else 'disarm', [vehicle])

    def wait_for_offboard_and_armed(self, vehicles, timeout_s, what='OFFBOARD and armed'):
        """Every one of vehicles (a Vehicle or a list) in OFFBOARD and armed at once."""
        vehicles = vehicles if isinstance(vehicles, (list, tuple)) else [vehicles]
        self.wait_until(lambda: all(v.offboard_and_armed() for v in vehicles), timeout_s, what, vehicles)

    def wait_for_altitude(self, vehicle, z_m, tolerance_m, timeout_s):
        """A pose within tolerance_m of z_m (ENU, m) within timeout_s: any pose that came since the wait began
        (_reached), as wait_for_position; else fail saying where the vehicle came closest."""
        self.wait_until(_reached(vehicle, lambda p: abs(p[2] - z_m) <= tolerance_m), timeout_s,
                        'altitude %.2f +- %.2f m' % (z_m, tolerance_m), [vehicle],
                        closest=lambda start: _closest(vehicle, start, lambda p: abs(p[2] - z_m),
                                                       lambda p: '%+.2f m from it' % (p[2] - z_m)))

    def wait_back_at_2m(self, vehicle, what, timeout_s=60.0, tolerance_m=0.2):
        """OFFBOARD and armed again after `what` within timeout_s, then at 2 m within 30 s."""
        self.wait_for_offboard_and_armed(vehicle, timeout_s, 'OFFBOARD and armed again after %s' % what)
        self.wait_for_altitude(vehicle, 2.0, tolerance_m, 30.0)

    def assert_holds(self, vehicle, z_m, tolerance_m, duration_s):
        """Every pose for duration_s stays within tolerance of z_m."""
        start = now()
        self.pause(duration_s)
        with vehicle.lock:
            samples = [p[2] for t, p in vehicle.positions if t >= start]
        self.assertGreater(len(samples), duration_s * 10, 'too few poses (%d) in %.0f s' % (len(samples), duration_s))
        worst = max(samples, key=lambda z: abs(z - z_m))
        self.assertLessEqual(abs(worst - z_m), tolerance_m,
                             'did not hold %.2f +- %.2f m for %.0f s: reached %.3f m (%s)'
                             % (z_m, tolerance_m, duration_s, worst, vehicle.describe()))

    def wait_for_position(self, vehicle, position_enu, timeout_s, horizontal_m=1.0, vertical_m=0.2):
        """"Reached": a pose of the vehicle within horizontal_m (in x, y) and vertical_m (in z) of position_enu,
        an (x, y, z) ENU in metres, within timeout_s (any pose that came, the vehicle may have gone on since);
        else fail saying where it was and where it came closest. The defaults
        allow PX4 SITL's hover wander over a few seconds (xy up to 0.6 m, z +- 0.1 m; over 80 s its z wandered
        0.24 m, reference/px4-sitl-hover.json)."""
        def excess(p):
            horizontal, vertical = _offset(p, position_enu)
            return max(horizontal / horizontal_m, vertical / vertical_m)

        def off(p):
            horizontal, vertical = _offset(p, position_enu)
            return '%.2f m horizontally, %+.2f m vertically from it' % (horizontal, p[2] - position_enu[2])
        what = ('position ENU (%.2f, %.2f, %.2f) +- %.2f m horizontally, +- %.2f m vertically'
                % (tuple(position_enu) + (horizontal_m, vertical_m)))
        self.wait_until(_reached(vehicle, lambda p: excess(p) <= 1.0), timeout_s, what, [vehicle],
                        closest=lambda start: _closest(vehicle, start, excess, off))

    def assert_holds_position(self, vehicle, position_enu, duration_s, horizontal_m=1.0, vertical_m=0.2):
        """"Held": every pose for duration_s within horizontal_m (x, y) and vertical_m (z) of
        position_enu (x, y, z ENU, m), at least 10 poses a second; else fail with the pose furthest
        out and when it came."""
        start = now()
        self.pause(duration_s)
        with vehicle.lock:
            samples = [(t, p) for t, p in vehicle.positions if t >= start]
        self.assertGreater(len(samples), duration_s * 10, 'too few poses (%d) in %.0f s: %s'
                           % (len(samples), duration_s, vehicle.describe()))

        def excess(sample):
            horizontal, vertical = _offset(sample[1], position_enu)
            return max(horizontal / horizontal_m, vertical / vertical_m)
        t, worst = max(samples, key=excess)
        self.assertLessEqual(excess((t, worst)), 1.0,
                             'did not hold ENU (%.2f, %.2f, %.2f) +- %.2f m horizontally, +- %.2f m vertically for '
                             '%.0f s: at (%.2f, %.2f, %.2f) %.1f s in (%s)'
                             % (tuple(position_enu) + (horizontal_m, vertical_m, duration_s) + tuple(worst)
                                + (t - start, vehicle.describe())))

    def wait_for_failsafe(self, vehicle, loss_timeout_s=1.0, slack_s=0.3, state_period_s=1.0, timeout_s=10.0):
        """Failsafe timing, once the node under test has stopped streaming setpoints (killed, or told
        to stop): the vehicle leaves OFFBOARD not before loss_timeout_s (PX4's COM_OF_LOSS_T, 1 s
        in PX4 and in the simulator) after the last setpoint the node sent (on any setpoint topic
        of mavros), and not after loss_timeout_s + slack_s + state_period_s (mavros
        publishes the mode with each HEARTBEAT, 1 Hz, so it tells of a change up to a period late)
        + late_s() (a busy machine).
        Waits at most timeout_s; returns (delay_s, mode): from the last setpoint to the first state
        out of OFFBOARD, and that mode (AUTO.RTL without RC, as PX4's NAV_RCL_ACT)."""
        def left_offboard():
            setpoints = vehicle.setpoints
            if not setpoints:
                return None
            return next(((t, s.mode) for t, s in vehicle.states_since(setpoints[-1]) if s.mode != 'OFFBOARD'), None)
        self.wait_until(left_offboard, timeout_s, 'leaving OFFBOARD after the last setpoint of the node under test '
                        '(%s)' % (', '.join('%d on %s' % kv for kv in sorted(vehicle.setpoint_counts().items()))
                                  or 'none seen on any setpoint topic'), [vehicle])
        when, mode = left_offboard()
        delay = when - vehicle.setpoints[-1]
        self.assertGreaterEqual(delay, loss_timeout_s - 0.05,
                                'left OFFBOARD for %s %.2f s after the last setpoint, before COM_OF_LOSS_T %.1f s: '
                                'the failsafe was not the offboard loss (%s)' % (mode, delay, loss_timeout_s,
                                                                                 vehicle.describe()))
        self.assertLessEqual(delay, loss_timeout_s + slack_s + state_period_s + self.late_s(),
                             'left OFFBOARD for %s %.2f s after the last setpoint: later than COM_OF_LOSS_T %.1f s '
                             '+ %.1f s + a state period %.1f s + %.1f s of a busy machine (%s)'
                             % (mode, delay, loss_timeout_s, slack_s, state_period_s, self.late_s(),
                                vehicle.describe()))
        return delay, mode

    def call_service(self, proxy, timeout_s, **request):
        """proxy(**request), failing with the service's name when it is not there, or has not
        answered, within timeout_s (ROS time) in all. A rospy.ServiceException from the call is raised."""
        deadline = now() + timeout_s
        try:
            proxy.wait_for_service(timeout_s)  # wall seconds: at least as long as timeout_s of a faster clock
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
        while worker.is_alive() and now() < deadline and not rospy.is_shutdown():
            worker.join(0.02)
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
    return frames.quaternion_yaw(_quaternion(q))
