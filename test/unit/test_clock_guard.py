"""The scenarios' clock guard (offboard_py.testing.rostest_common.ClockGuard): a lag that goes as soon as the
node's threads run again (a stall of the test node) is no verdict on the machine; a lag that stays is.
ROS time is set directly here (rospy.rostime), as a /clock subscription sets it."""

import threading
import time

import pytest
import rospy
import rospy.rostime

from offboard_py.testing import rostest_common
from offboard_py.testing.rostest_common import CATCH_UP_WALL_S, MAX_CLOCK_LAG_S, ClockGuard

SPEED = 5.0


@pytest.fixture
def guard(monkeypatch):
    monkeypatch.setattr(rostest_common, '_sim_time', lambda: True)
    rospy.rostime.set_rostime_initialized(True)
    g = ClockGuard.__new__(ClockGuard)  # without the parameter server: the speed is given
    g.speed, g.worst_s, g.stalls = SPEED, 0.0, 0
    yield g
    rospy.rostime.set_rostime_initialized(False)


def set_ros_time_behind(lag_s):
    rospy.rostime._set_rostime(rospy.Time.from_sec(SPEED * time.monotonic() - lag_s))


def test_a_lag_within_the_bound_is_no_problem(guard):
    set_ros_time_behind(MAX_CLOCK_LAG_S / 2)
    assert guard.problem() is None
    assert guard.stalls == 0


def test_a_lag_that_goes_when_the_ticks_are_taken_is_a_stall_not_a_failure(guard):
    set_ros_time_behind(0.73)  # 0.15 s of wall time at 5x, as read in CI
    ticks = threading.Timer(0.03, set_ros_time_behind, (0.05,))  # the queued /clock ticks taken
    ticks.start()
    started = time.monotonic()
    assert guard.problem() is None
    ticks.join()
    assert guard.stalls == 1
    assert time.monotonic() - started < CATCH_UP_WALL_S


def test_a_lag_that_stays_fails_naming_it_and_the_speed(guard):
    set_ros_time_behind(2.0)
    started = time.monotonic()
    message = guard.problem()
    assert time.monotonic() - started >= CATCH_UP_WALL_S
    assert message is not None and guard.stalls == 0
    assert "behind the vehicles' clock at 5x" in message and 'cannot keep up' in message, message
    assert guard.worst_s >= 2.0
