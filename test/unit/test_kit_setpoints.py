"""The test kit's Vehicle sees every setpoint a mavros user sends (offboard_py.testing.rostest_common):
each of mavros 1.21's setpoint topics, and of a raw message only the fields its type_mask does not ignore;
and what its waits look at. No ROS master: the message classes, the decoding and the predicates only."""

import math
import os
import re

from geographic_msgs.msg import GeoPoseStamped
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from mavros_msgs.msg import AttitudeTarget, GlobalPositionTarget, PositionTarget, Thrust

from offboard_py.testing import rostest_common
from offboard_py.testing.rostest_common import SETPOINT_TOPICS

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
FIELDS = {topic: fields for topic, _, fields in SETPOINT_TOPICS}
# mavros 1.21's setpoint plugins subscribe to these (setpoint_position, setpoint_raw, setpoint_velocity,
# setpoint_attitude); setpoint_accel/accel is not in the bridge (docs/bridge.md)
MAVROS_SETPOINT_TOPICS = {
    'setpoint_position/local', 'setpoint_position/global', 'setpoint_raw/local', 'setpoint_raw/global',
    'setpoint_raw/attitude', 'setpoint_velocity/cmd_vel', 'setpoint_velocity/cmd_vel_unstamped',
    'setpoint_attitude/attitude', 'setpoint_attitude/cmd_vel', 'setpoint_attitude/thrust'}


def test_every_setpoint_topic_the_bridge_takes_is_watched():
    watched = set(FIELDS)
    assert watched == MAVROS_SETPOINT_TOPICS
    bridge = ''
    for name in ('setpoint.py', 'setpoint_attitude.py'):
        with open(os.path.join(REPO, 'src', 'offboard_py', 'bridge', name)) as f:
            bridge += f.read()
    taken = set(re.findall(r"subscriber\('~(setpoint_[a-z_]+/[a-z_]+)'", bridge))
    assert taken == watched


def test_position_local_gives_position_and_yaw():
    msg = PoseStamped()
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = 1.0, 2.0, 3.0
    msg.pose.orientation.z, msg.pose.orientation.w = math.sin(0.25), math.cos(0.25)  # yaw 0.5 rad
    fields = FIELDS['setpoint_position/local'](msg)
    assert fields['position'] == (1.0, 2.0, 3.0) and abs(fields['yaw'] - 0.5) < 1e-9


def test_raw_local_keeps_only_what_the_type_mask_uses():
    msg = PositionTarget(coordinate_frame=PositionTarget.FRAME_LOCAL_NED, yaw_rate=0.3)
    msg.velocity.x, msg.velocity.y, msg.velocity.z = 1.0, -1.0, 0.5
    msg.position.z = 9.0
    msg.type_mask = (PositionTarget.IGNORE_PX | PositionTarget.IGNORE_PY | PositionTarget.IGNORE_PZ
                     | PositionTarget.IGNORE_AFX | PositionTarget.IGNORE_AFY | PositionTarget.IGNORE_AFZ
                     | PositionTarget.IGNORE_YAW)
    fields = FIELDS['setpoint_raw/local'](msg)
    assert fields == {'frame': PositionTarget.FRAME_LOCAL_NED, 'velocity': (1.0, -1.0, 0.5), 'yaw_rate': 0.3}
    msg.type_mask = PositionTarget.IGNORE_VX | PositionTarget.IGNORE_VY | PositionTarget.IGNORE_VZ | \
        PositionTarget.IGNORE_AFX | PositionTarget.IGNORE_AFY | PositionTarget.IGNORE_AFZ | PositionTarget.IGNORE_YAW_RATE
    fields = FIELDS['setpoint_raw/local'](msg)
    assert set(fields) == {'frame', 'position', 'yaw'} and fields['position'] == (0.0, 0.0, 9.0)


def test_raw_global_gives_the_geodetic_position():
    msg = GlobalPositionTarget(latitude=47.4, longitude=8.5, altitude=500.0,
                               type_mask=GlobalPositionTarget.IGNORE_VX | GlobalPositionTarget.IGNORE_VY
                               | GlobalPositionTarget.IGNORE_VZ | GlobalPositionTarget.IGNORE_AFX
                               | GlobalPositionTarget.IGNORE_AFY | GlobalPositionTarget.IGNORE_AFZ
                               | GlobalPositionTarget.IGNORE_YAW | GlobalPositionTarget.IGNORE_YAW_RATE)
    assert FIELDS['setpoint_raw/global'](msg) == {'frame': 0, 'global': (47.4, 8.5, 500.0)}


def test_attitude_targets_and_the_rest():
    msg = AttitudeTarget(type_mask=AttitudeTarget.IGNORE_ROLL_RATE | AttitudeTarget.IGNORE_PITCH_RATE
                         | AttitudeTarget.IGNORE_YAW_RATE, thrust=0.6)
    msg.orientation.w = 1.0
    assert FIELDS['setpoint_raw/attitude'](msg) == {'attitude': (0.0, 0.0, 0.0, 1.0), 'thrust': 0.6}
    msg.type_mask = AttitudeTarget.IGNORE_ATTITUDE
    msg.body_rate.z = 0.2
    assert FIELDS['setpoint_raw/attitude'](msg) == {'body_rate': (0.0, 0.0, 0.2), 'thrust': 0.6}
    twist = TwistStamped()
    twist.twist.linear.x, twist.twist.angular.z = 2.0, 0.1
    assert FIELDS['setpoint_velocity/cmd_vel'](twist) == {'velocity': (2.0, 0.0, 0.0), 'angular': (0.0, 0.0, 0.1)}
    assert FIELDS['setpoint_velocity/cmd_vel_unstamped'](Twist())['velocity'] == (0.0, 0.0, 0.0)
    assert FIELDS['setpoint_attitude/cmd_vel'](twist) == {'body_rate': (0.0, 0.0, 0.1)}
    assert FIELDS['setpoint_attitude/thrust'](Thrust(thrust=0.4)) == {'thrust': 0.4}
    geo = GeoPoseStamped()
    geo.pose.position.latitude, geo.pose.orientation.w = 47.0, 1.0
    assert FIELDS['setpoint_position/global'](geo) == {'global': (47.0, 0.0, 0.0), 'yaw': 0.0}


def test_closest_approach_says_where_and_when():
    class Seen:
        lock = rostest_common.threading.Lock()
        positions = [(10.0, (0.0, 0.0, 0.5)), (11.0, (0.0, 0.0, 0.9)), (12.0, (0.0, 0.0, 0.7)), (9.0, (0, 0, 2.0))]
    text = rostest_common._closest(Seen(), 10.0, lambda p: abs(p[2] - 2.0), lambda p: '%+.2f m from it' % (p[2] - 2.0))
    assert text == 'ENU (0.00, 0.00, 0.90) at 1.0 s into the wait, -1.10 m from it', 'before the wait does not count'
    assert rostest_common._closest(Seen(), 20.0, abs, str) == 'no pose since the wait began'


def test_a_mode_shown_for_one_heartbeat_between_two_looks_counts():
    """wait_for_mode's predicate (_seen) looks at every state since the wait began: the default node takes
    OFFBOARD back at the first AUTO.LOITER state, and a look after it must still see the pilot's switch."""
    from mavros_msgs.msg import State

    class Seen:
        lock = rostest_common.threading.Lock()
        state = State(mode='OFFBOARD')
        states = [(1.0, State(mode='AUTO.LOITER')), (2.0, State(mode='OFFBOARD'))]  # before the wait

    vehicle = Seen()
    predicate = rostest_common._seen(vehicle, lambda s: s.mode == 'AUTO.LOITER')
    assert not predicate(), 'a state from before the wait does not count'
    vehicle.states += [(3.0, State(mode='AUTO.LOITER')), (4.0, State(mode='OFFBOARD'))]
    vehicle.state = vehicle.states[-1][1]
    assert predicate(), 'AUTO.LOITER came and went between two looks'
    assert rostest_common._seen(vehicle, lambda s: s.mode == 'OFFBOARD')(), 'the newest state counts at once'
    assert not rostest_common._seen(vehicle, lambda s: s.armed)(), 'nothing armed since'
    since_3 = rostest_common._seen(vehicle, lambda s: s.mode == 'AUTO.LOITER', since=3.0)
    assert since_3(), 'a state received at the time given counts, though it came before the wait'
    assert not rostest_common._seen(vehicle, lambda s: s.mode == 'AUTO.LOITER', since=3.5)(), 'nor one before it'


def test_a_pose_passed_through_between_two_looks_counts():
    """wait_for_position's and wait_for_altitude's predicate (_reached) looks at every pose since the wait
    began: a vehicle that turns at a corner, or overshoots through 2 m, is inside for less than a look's delay."""
    class Seen:
        lock = rostest_common.threading.Lock()
        positions = [(1.0, (0.0, 0.0, 2.0))]  # before the wait

    vehicle = Seen()
    at_2m = rostest_common._reached(vehicle, lambda p: abs(p[2] - 2.0) <= 0.1)
    assert not at_2m(), 'a pose from before the wait does not count'
    vehicle.positions += [(2.0, (0.0, 0.0, 1.5)), (2.1, (0.0, 0.0, 1.95)), (2.2, (0.0, 0.0, 2.3))]
    assert at_2m(), '1.95 m came and went between two looks'
    assert not rostest_common._reached(vehicle, lambda p: True)(), 'a new predicate starts after the poses it had'
