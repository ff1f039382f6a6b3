"""A ROS node as a participant of the run's governed clock (offboard_py.clock_board): in simulated time, a
thread writes the node's ROS time (the last /clock it took) into its slot of the board 100 times a wall
second, so the clock waits while this node falls behind (starved of CPU) instead of running on without it.
Nothing in real time, nor in simulated time without a board."""

import os
import threading
import time

import rospy

from offboard_py.clock_board import Board, BoardError, board_path

UPDATE_WALL_S = 0.01


class RosParticipant:
    """The slot of this node, kept up to date by a daemon thread until leave()."""

    def __init__(self, board, name, limit=None):
        """limit(): a simulated time this participant must not be taken past, or None (the bridge's setpoint
        streams: offboard_py.stream_watch). The node joins with its first /clock: before it, it has no time to
        keep up with, and nothing of it runs on the vehicles' clock."""
        self.board, self.name = board, name
        self.limit = limit
        self.participant = None
        self.running = True
        self.thread = threading.Thread(target=self._run, name='clock participant', daemon=True)
        self.thread.start()

    def _run(self):
        try:
            while self.running and not rospy.core.is_shutdown():
                t = rospy.get_time()
                if t > 0.0:
                    if self.participant is None:
                        self.participant = self.board.join(self.name)
                    held = self.limit() if self.limit is not None else None
                    self.participant.update(t if held is None else min(t, held))
                time.sleep(UPDATE_WALL_S)
        except BoardError as err:  # every slot taken: the run goes on without this node, and says so
            rospy.logwarn('%s: not a participant of the governed clock: %s', self.name, err)
        finally:
            if self.participant is not None:
                self.participant.leave()

    def leave(self):
        self.running = False


def join(name, limit=None):
    """The node's RosParticipant in simulated time with a board, else None. Needs rospy.init_node first."""
    if rospy.get_param('/use_sim_time', False) is not True:
        return None
    try:
        speed = float(rospy.get_param('/sim_clock/speed', 1.0))
        path = board_path(speed)
        return RosParticipant(Board(path, speed), name, limit) if path else None
    except (BoardError, ValueError) as err:
        rospy.logwarn('%s: not a participant of the governed clock: %s', name, err)
        return None


def waits_for_cpu(pid, proc='/proc'):
    """True while a thread of process `pid` is runnable (state R in /proc/PID/task/*/stat): it wants the CPU
    it is not given, or is on it. False for a process whose threads all sleep, or that is gone."""
    try:
        tasks = os.listdir(os.path.join(proc, str(pid), 'task'))
    except OSError:
        return False
    for task in tasks:
        try:
            with open(os.path.join(proc, str(pid), 'task', task, 'stat')) as f:
                stat = f.read()
        except OSError:
            continue
        if stat[stat.rfind(')') + 2:stat.rfind(')') + 3] == 'R':
            return True
    return False


class PublisherProcesses:
    """The local process of each node that publishes to this one, by caller id, for
    stream_watch.StreamWatch(runnable=...): looked up once (the master's URI of the node, then the node's
    getPid), from a thread of its own, since a starved node answers late or not at all. A node on another host,
    or one that does not answer, has none: it is never taken for a process that waits for the CPU."""

    LOCAL_HOSTS = ('localhost', '127.0.0.1', '::1')

    def __init__(self, caller_id):
        self.caller_id = caller_id
        self.pids = {}
        self.lock = threading.Lock()

    def seen(self, publisher):
        """A publisher's message arrived: look its process up if not yet done (cheap once known)."""
        if publisher in self.pids:
            return
        with self.lock:
            if publisher in self.pids:
                return
            self.pids[publisher] = None
        threading.Thread(target=self._look_up, args=(publisher,), name='publisher pid', daemon=True).start()

    def _look_up(self, publisher):
        import socket
        import xmlrpc.client
        from urllib.parse import urlparse

        import rosgraph
        try:
            uri = rosgraph.Master(self.caller_id).lookupNode(publisher)
            host = urlparse(uri).hostname
            if host not in self.LOCAL_HOSTS + (socket.gethostname(),) and not host.startswith('127.'):
                return
            code, _, pid = xmlrpc.client.ServerProxy(uri).getPid(self.caller_id)
            if code == 1 and isinstance(pid, int) and pid > 0:
                self.pids[publisher] = pid
        except Exception:  # gone, refused, not a node: none known, so it never holds the clock long
            pass

    def waits_for_cpu(self, publisher):
        pid = self.pids.get(publisher)
        return pid is not None and waits_for_cpu(pid)
