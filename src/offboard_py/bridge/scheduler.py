"""The bridge's timers and its retries, on the bridge's clock (monotonic wall time, or ROS time
under /use_sim_time, as mavros's ros::Timer follows /clock).

- `Scheduler`: periodic tasks (every) and one-shots (after), run by the receive thread when due
  (run_due); next_due_s() tells that thread when to wake. A task runs at the first wake-up at or
  after its due time, so while the FCU streams the timers run in the wake-ups its datagrams cause,
  up to TIMER_SLACK_S late; a periodic task stays on its schedule (due + period), so its rate is
  exact. A one-shot runs in a thread of its own (a pull may wait seconds for the FCU).
- `retry(what, attempt, ...)`: the back-off of a connection-time pull, as a policy of its own.
No ROS and no socket here: errors and warnings go to the logger the caller gives.
"""

import itertools
import threading

# How late a periodic task may run (bridge clock) so that it runs in a wake-up the FCU's datagrams
# cause anyway (PX4 sends hundreds a second) instead of one of its own.
TIMER_SLACK_S = 0.02
RETRY_DELAYS_S = (1.0, 2.0, 4.0, 8.0, 16.0, 30.0)  # between tries of a connection-time pull; then every 30 s


class Scheduler:
    def __init__(self, clock, log_error):
        """`clock()`: seconds; `log_error(text, *args, exc_info=True)` reports a task that raised."""
        self.clock = clock
        self.log_error = log_error
        self.periodic = []   # [period_s, next_s, callback]
        self.one_shots = []  # (due_s, callback)
        self.added = False   # a task was added since the receive thread last asked next_due_s()

    def every(self, period_s, callback):
        """Call callback(now_s) every period_s; returns the task (for take_early)."""
        task = [period_s, self.clock(), callback]
        self.periodic.append(task)
        self.added = True
        return task

    def after(self, delay_s, callback):
        """Call callback() once, delay_s from now, in a thread of its own."""
        self.one_shots.append((self.clock() + delay_s, callback))
        self.added = True

    @staticmethod
    def take_early(task, now_s):
        """True, and the periodic task counted as run, when its next run is due within one period
        of now_s: its caller does the work now, in step with something else; the schedule (and so
        the rate) stays that of every()."""
        if task[1] - now_s >= task[0]:
            return False
        task[1] = max(task[1], now_s) + task[0]
        return True

    def run_due(self, now_s):
        """Run every task due at now_s: the periodic callbacks, then the one-shots."""
        self.run_periodic(now_s)
        if self.one_shots:
            due = [task for task in self.one_shots if now_s >= task[0]]
            for task in due:
                self.one_shots.remove(task)
                threading.Thread(target=task[1], name='after-connect', daemon=True).start()

    def run_periodic(self, now_s):
        for task in self.periodic:
            if now_s >= task[1]:
                task[1] = max(task[1] + task[0], now_s)
                try:
                    task[2](now_s)
                except Exception:  # a plugin bug must not stop the link
                    self.log_error('periodic task %r failed', task[2], exc_info=True)

    def next_due_s(self):
        """When the receive thread must wake for the tasks: the earliest due time plus TIMER_SLACK_S;
        None without any task."""
        self.added = False
        due = [task[1] for task in self.periodic] + [task[0] for task in self.one_shots]
        return min(due) + TIMER_SLACK_S if due else None


def retry(what, attempt, stop, pause, log, delays=None):
    """attempt() -> (done, detail) until done, with pause(seconds) between tries backing off by
    `delays`. stop() -> None while the tries should go on, else why they end ('': quietly, e.g. at
    shutdown; else logged as an error with the last failure). Each failed try is a warning. `log` has
    rospy's loginfo/logwarn/logerr. True once done."""
    delays = delays or RETRY_DELAYS_S
    for tries in itertools.count(1):
        if stop() is not None:
            return False
        done, detail = attempt()
        if done:
            if tries > 1:
                log.loginfo('%s succeeded at try %d', what, tries)
            return True
        why = stop()
        if why is not None:
            if why:
                log.logerr('%s failed: %s; %s', what, detail, why)
            return False
        delay = delays[min(tries - 1, len(delays) - 1)]
        log.logwarn('%s failed: %s; trying again in %.0f s (try %d)', what, detail, delay, tries + 1)
        pause(delay)
