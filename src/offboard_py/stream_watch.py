"""The node under test as the bridge sees it, for the governed clock (offboard_py.clock_board): a node that
streams setpoints steadily and then falls silent may be starved of CPU rather than stopped. For HOLD_WALL_S of
wall time the clock may not run further than two of its periods past its last setpoint; past that, for as long
as the node's process waits for the CPU (a thread of it runnable and not running: `runnable(publisher)`, read
from /proc where the node runs on this host) up to STARVED_HOLD_WALL_S. A node silent and not waiting to run
has stopped (killed, or done, or pausing on purpose) and the clock goes on without it. The offboard-loss
failsafe is timed in simulated seconds, which stand still meanwhile: the wait moves no deadline. StreamWatch is
pure (the arrivals' simulated and wall times, and whether a publisher waits to run, are given);
ros_participant.waits_for_cpu is what reads /proc for it (PublisherProcesses finds the process)."""

STEADY_COUNT = 20          # setpoints before a stream counts as steady
MAX_PERIOD_S = 0.5         # simulated seconds: slower than 2 Hz is not a stream PX4's offboard mode keeps
HOLD_WALL_S = 0.5          # wall seconds any silent steady stream holds the clock
STARVED_HOLD_WALL_S = 10.0  # and at most this long while its node's process waits for the CPU (clock_board's stale time)
ALPHA = 0.1                # smoothing of the period


class Stream:
    __slots__ = ('count', 'period_s', 'last_s', 'last_wall_s', 'let_go')

    def __init__(self, sim_s, wall_s):
        self.count, self.period_s, self.last_s, self.last_wall_s = 1, None, sim_s, wall_s
        self.let_go = False  # silent past the hold: the clock went on without it (said once, by let_go())

    def steady(self):
        return self.count >= STEADY_COUNT and self.period_s is not None and self.period_s <= MAX_PERIOD_S


class StreamWatch:
    """Setpoint streams by publisher (a ROS caller id). runnable(publisher): True while that node's process
    waits for the CPU, False when it does not (or cannot be known)."""

    def __init__(self, hold_wall_s=HOLD_WALL_S, starved_hold_wall_s=STARVED_HOLD_WALL_S, runnable=None):
        self.hold_wall_s, self.starved_hold_wall_s = hold_wall_s, starved_hold_wall_s
        self.runnable = runnable or (lambda publisher: False)
        self.streams = {}
        self._asked = (None, False)  # ((publisher, wall_s), its answer): limit() and let_go() of one tick ask once

    def arrived(self, publisher, sim_s, wall_s):
        stream = self.streams.get(publisher)
        if stream is None:
            self.streams[publisher] = Stream(sim_s, wall_s)
            return
        gap = sim_s - stream.last_s
        if gap > 0:
            stream.period_s = gap if stream.period_s is None else (1 - ALPHA) * stream.period_s + ALPHA * gap
        stream.count += 1
        stream.last_s, stream.last_wall_s = max(stream.last_s, sim_s), wall_s
        stream.let_go = False

    def _holding(self, publisher, stream, wall_s):
        if not stream.steady() or stream.let_go:
            return False
        silent = wall_s - stream.last_wall_s
        return silent < self.hold_wall_s or (silent < self.starved_hold_wall_s and self._runnable(publisher, wall_s))

    def _runnable(self, publisher, wall_s):
        if self._asked[0] != (publisher, wall_s):
            self._asked = ((publisher, wall_s), self.runnable(publisher))
        return self._asked[1]

    def limit(self, wall_s):
        """The simulated time the clock may run to for the streams' sake, or None (no stream holds it)."""
        limits = [s.last_s + 2 * s.period_s for p, s in list(self.streams.items()) if self._holding(p, s, wall_s)]
        return min(limits) if limits else None

    def let_go(self, wall_s):
        """[(publisher, simulated s of its last setpoint, wall s silent)] of the steady streams that no longer
        hold the clock, each once until it streams again: the clock goes on without them (an offboard-loss
        failsafe may follow), which the bridge says."""
        gone = []
        for publisher, s in list(self.streams.items()):
            if s.steady() and not s.let_go and not self._holding(publisher, s, wall_s):
                s.let_go = True
                gone.append((publisher, s.last_s, wall_s - s.last_wall_s))
        return gone

    def forget(self, publisher):
        """Its connection closed (the node ended): it holds nothing."""
        self.streams.pop(publisher, None)
