"""The scenarios' clock guard (offboard_py.testing.rostest_common.ClockGuard): a lag that goes as soon as the
node's threads run again (a stall of the test node) is no verdict on the machine; a lag that stays is.
ROS time is set directly here (rospy.rostime), as a /clock subscription sets it, and the guard's wall clock is a
fake one that only its own sleeps move, so a busy machine cannot change what these tests see."""

import types

import pytest
import rospy
import rospy.rostime

from offboard_py.testing import rostest_common
from offboard_py.testing.rostest_common import CATCH_UP_WALL_S, MAX_CLOCK_LAG_S, ClockGuard

SPEED = 5.0


class WallClock:
    """The guard's time.monotonic and time.sleep; `during_sleep` runs at each sleep (the node's other
    threads taking their turn)."""

    def __init__(self):
        self.now_s = 1000.0
        self.slept_s = 0.0
        self.during_sleep = lambda: None

    def monotonic(self):
        return self.now_s

    def sleep(self, seconds):
        self.now_s += seconds
        self.slept_s += seconds
        self.during_sleep()


@pytest.fixture
def wall(monkeypatch):
    clock = WallClock()
    monkeypatch.setattr(rostest_common, 'time', types.SimpleNamespace(monotonic=clock.monotonic, sleep=clock.sleep))
    monkeypatch.setattr(rostest_common, '_sim_time', lambda: True)
    rospy.rostime.set_rostime_initialized(True)
    yield clock
    rospy.rostime.set_rostime_initialized(False)


@pytest.fixture
def guard(wall):
    g = ClockGuard.__new__(ClockGuard)  # without the parameter server: the speed is given
    g.speed, g.worst_s, g.stalls, g.participant = SPEED, 0.0, 0, None  # no board: speed x the monotonic clock
    return g


def ros_time_behind(wall, lag_s):
    """ROS time as the last /clock tick taken left it: lag_s (simulated) behind the vehicles' clock."""
    rospy.rostime._set_rostime(rospy.Time.from_sec(SPEED * wall.now_s - lag_s))


def test_a_lag_within_the_bound_is_no_problem(wall, guard):
    ros_time_behind(wall, MAX_CLOCK_LAG_S / 2)
    assert guard.problem() is None
    assert guard.stalls == 0 and wall.slept_s == 0.0


def test_a_lag_that_goes_when_the_ticks_are_taken_is_a_stall_not_a_failure(wall, guard):
    ros_time_behind(wall, 0.73)  # 0.15 s of wall time at 5x, as read in CI
    wall.during_sleep = lambda: ros_time_behind(wall, 0.05)  # the queued /clock ticks taken
    assert guard.problem() is None
    assert guard.stalls == 1
    assert wall.slept_s < CATCH_UP_WALL_S


def test_a_lag_that_stays_fails_naming_it_and_the_speed(wall, guard):
    ros_time_behind(wall, 2.0)
    message = guard.problem()
    assert wall.slept_s >= CATCH_UP_WALL_S
    assert message is not None and guard.stalls == 0
    assert "behind the vehicles' clock at 5x" in message and 'cannot keep up' in message, message
    assert guard.worst_s >= 2.0
