"""The node under test as the bridge sees it, for the governed clock (offboard_py.clock_board): a node that
streams setpoints steadily and then falls silent may be starved of CPU rather than stopped, so for a short
while (HOLD_WALL_S of wall time) the clock may not run further than two of its periods past its last
setpoint; a node that is still silent then has stopped (killed, or done), and the clock goes on without it.
The offboard-loss failsafe is timed in simulated seconds, which stand still meanwhile: the wait moves no
deadline. Pure: the arrivals' simulated and wall times are given."""

STEADY_COUNT = 20      # setpoints before a stream counts as steady
MAX_PERIOD_S = 0.5     # simulated seconds: slower than 2 Hz is not a stream PX4's offboard mode keeps
HOLD_WALL_S = 2.0      # wall seconds a silent steady stream may hold the clock (a thread starved while its process runs)
ALPHA = 0.1            # smoothing of the period


class Stream:
    __slots__ = ('count', 'period_s', 'last_s', 'last_wall_s', 'let_go')

    def __init__(self, sim_s, wall_s):
        self.count, self.period_s, self.last_s, self.last_wall_s = 1, None, sim_s, wall_s
        self.let_go = False  # silent past the hold: the clock went on without it (said once, by let_go())

    def steady(self):
        return self.count >= STEADY_COUNT and self.period_s is not None and self.period_s <= MAX_PERIOD_S


class StreamWatch:
    """Setpoint streams by publisher (a ROS caller id)."""

    def __init__(self, hold_wall_s=HOLD_WALL_S):
        self.hold_wall_s = hold_wall_s
        self.streams = {}

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

    def limit(self, wall_s):
        """The simulated time the clock may run to for the streams' sake, or None (no stream holds it)."""
        limits = [s.last_s + 2 * s.period_s for s in list(self.streams.values())
                  if s.steady() and wall_s - s.last_wall_s < self.hold_wall_s]
        return min(limits) if limits else None

    def let_go(self, wall_s):
        """[(publisher, simulated s of its last setpoint)] of the steady streams that have now been silent past
        the hold, each once until it streams again: the clock goes on without them (an offboard-loss failsafe may
        follow), which the bridge says."""
        gone = []
        for publisher, s in list(self.streams.items()):
            if not s.let_go and s.steady() and wall_s - s.last_wall_s >= self.hold_wall_s:
                s.let_go = True
                gone.append((publisher, s.last_s))
        return gone

    def forget(self, publisher):
        """Its connection closed (the node ended): it holds nothing."""
        self.streams.pop(publisher, None)
