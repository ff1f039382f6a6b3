"""The /clock node (ROS node and script `sim_clock`): publishes /clock for a run in simulated time (its
formula: offboard_py.simtime.SimClock).

The simulated PX4s step on `speed` x the host's monotonic clock; this node publishes the
same formula on /clock, so every ROS node with /use_sim_time (rospy timers, rospy.Rate,
the bridge's timeouts, offb_node's 5 s request spacing) runs on the vehicles' seconds. One
sim_clock serves every vehicle of a ROS master: they compute the same clock.

Ticks are every `~period` simulated seconds (default 0.01 s: 100 Hz of simulated time, what
gazebo_ros publishes at pub_clock_frequency 100), on a grid of that period, never backwards.
sim_clock.launch makes it 0.01 s x the speed: 100 ticks a second of wall time at any speed. Every
node with /use_sim_time takes each tick in Python (about 100 us of CPU), so at 5x a tick every
0.01 s of simulated time cost a scenario's nodes together a third of a core more.

The guard: a tick published more than `~max_lag` simulated seconds late means this
machine cannot keep the ROS side up with the vehicles at this speed; the node logs an error
saying so (and how late), and /sim_clock/lag_max (a parameter) carries the worst lag seen
for tests to check. `~fault_lag` (simulated seconds, default 0) is a fault for testing what
watches the clock: /clock then runs that far behind the vehicles, as on a machine that cannot
keep up, whatever the machine.
"""

import os
import time

import rospy
from rosgraph_msgs.msg import Clock

from offboard_py import clock_board, tcpros_out
from offboard_py.master import await_master_from_argv
from offboard_py.clock_board import STALE_WALL_S, BoardError
from offboard_py.simtime import SimClock, SpeedError, parse_speed

NODE_NAME = 'sim_clock'
DEFAULT_PERIOD_S = 0.01
DEFAULT_MAX_LAG_S = 0.25
LAG_PARAM = '/sim_clock/lag_max'
HOLDS_PARAM = '/sim_clock/holds'
GOVERN_PERIOD_S = 0.01  # wall seconds between two governing steps (the horizon moves 100 times a second)
HOLD_LOG_WALL_S = 0.5   # a hold longer than this is logged with who held the clock


class ClockTicks:
    """The grid of /clock values, in integer nanoseconds so a tick is exact. Pure."""

    def __init__(self, period_s, start_s):
        self.period_ns = max(1, int(round(period_s * 1e9)))
        self.next_ns = (int(start_s * 1e9) // self.period_ns + 1) * self.period_ns
        self.lag_max_s = 0.0

    @property
    def next_s(self):
        return self.next_ns / 1e9

    def due(self, now_s):
        """(tick_ns, late_s): the latest grid point passed by now_s, or None while none is due.
        Missed ticks are skipped: /clock never runs backwards and never repeats."""
        now_ns = int(now_s * 1e9)
        if now_ns < self.next_ns:
            return None
        late_s = (now_ns - self.next_ns) / 1e9
        self.lag_max_s = max(self.lag_max_s, late_s)
        tick_ns = now_ns // self.period_ns * self.period_ns
        self.next_ns = tick_ns + self.period_ns
        return tick_ns, late_s


def _read_float(name, default, check, what):
    value = rospy.get_param(name, default)
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise SpeedError('parameter %s must be %s, got %r' % (name, what, value)) from None
    if not check(value):
        raise SpeedError('parameter %s must be %s, got %r' % (name, what, value))
    return value


def main():
    exit_code = await_master_from_argv(NODE_NAME)
    if exit_code is not None:
        return exit_code
    try:
        rospy.init_node(NODE_NAME)
        speed = parse_speed(rospy.get_param('~speed', 1.0), 'parameter ~speed')
        period_s = _read_float('~period', DEFAULT_PERIOD_S, lambda v: 0.0005 <= v <= 1.0, 'seconds in 0.0005..1')
        max_lag_s = _read_float('~max_lag', DEFAULT_MAX_LAG_S, lambda v: v > 0.0, 'seconds > 0')
        fault_lag_s = _read_float('~fault_lag', 0.0, lambda v: 0.0 <= v <= 3600.0, 'seconds in 0..3600')
    except SpeedError as err:
        rospy.logfatal('%s', err)
        return 2
    except (rospy.ROSException, KeyboardInterrupt):
        return 0
    if not rospy.get_param('/use_sim_time', False):
        rospy.logwarn('sim_clock: /use_sim_time is not set: ROS nodes will not follow /clock')
    try:  # the governor of the run's clock board (offboard_py.clock_board): /clock is the governed clock
        clock = SimClock.for_run(speed)
    except BoardError as err:
        rospy.logfatal('sim_clock: %s', err)
        return 2
    if fault_lag_s:
        rospy.logwarn('sim_clock: fault_lag %g s: /clock runs that far behind the vehicles (a test fault)',
                      fault_lag_s)
    ticks = ClockTicks(period_s, clock.now() - fault_lag_s)
    # every node with /use_sim_time subscribes: written to each at once, without a thread a subscriber
    # (at 5x, 500 ticks a second: rospy's queue cost this node a quarter of a core with two subscribers)
    publisher = tcpros_out.Publisher('/clock', Clock, 10, tcpros_out.Flusher())
    rospy.set_param(LAG_PARAM, 0.0)
    rospy.loginfo('sim_clock: /clock at %gx real time, a tick every %g s of simulated time', speed, period_s)
    message = Clock()
    reported_lag_s = 0.0
    # fault_lag stands for a machine whose ROS side cannot keep up with an ungoverned clock: no governing then
    governor = Governor(clock.board) if clock.board is not None and not fault_lag_s else None
    try:
        while not rospy.core.is_shutdown():
            if governor is not None:
                governor.step()
            now_s = clock.now() - fault_lag_s
            due = ticks.due(now_s)
            if due is None:
                wait_s = clock.wall_s(ticks.next_s - now_s)
                time.sleep(wait_s if governor is None else min(wait_s, GOVERN_PERIOD_S))
                continue
            tick_ns, late_s = due
            message.clock.secs, message.clock.nsecs = divmod(tick_ns, 1000000000)
            publisher.publish(message)
            if late_s > max_lag_s and late_s > 2 * reported_lag_s:
                reported_lag_s = late_s
                rospy.set_param(LAG_PARAM, ticks.lag_max_s)
                rospy.logerr('sim_clock: /clock fell %.2f s (simulated) behind the vehicles at %gx: this machine '
                             'cannot keep the ROS side up at that speed; failsafes seen now are the machine\'s, '
                             'not the vehicle\'s (lower the speed)', late_s, speed)
    except (rospy.ROSException, KeyboardInterrupt):
        pass
    if governor is not None:
        governor.finish()
    return 0


class Governor:
    """The governing of a clock board from this node's loop, and the report of who held the clock."""

    def __init__(self, board, log=None):
        self.board = board
        self.log = log or rospy.loginfo
        clock_board.sweep()  # what killed runs left in /dev/shm
        self.holding, self.since = None, None
        self.reported_stale = set()

    def step(self, now=time.monotonic):
        holder, stale = self.board.govern()
        for name in set(stale) - self.reported_stale:
            rospy.logwarn('sim_clock: %s has not kept up for %.0f wall seconds: the clock goes on without it',
                          name, STALE_WALL_S)
        self.reported_stale = set(stale)
        if holder != self.holding:
            if self.holding is not None and now() - self.since > HOLD_LOG_WALL_S:
                self.log('sim_clock: the clock waited %.2f wall seconds for %s' % (now() - self.since, self.holding))
            self.holding, self.since = holder, now()

    def finish(self):
        holds, held_s, last = self.board.holds()
        try:
            rospy.set_param(HOLDS_PARAM, {'count': holds, 'wall_s': held_s, 'last': last})
        except (OSError, rospy.ROSException):  # the master went first
            pass
        if holds:
            rospy.loginfo('sim_clock: the clock waited %d times for its slowest participant, %.2f wall seconds in '
                          'all (the last for %s): the run took that much longer, and nothing missed a deadline',
                          holds, held_s, last)
        try:
            os.unlink(self.board.path)
        except OSError:
            pass
