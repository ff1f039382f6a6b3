"""The soak's rules: the seeded fault schedule, recovery after a fault, and the memory rule.

A soak keeps the stack hovering at 2 m while faults are done to it one after another, and
judges two things: every fault is recovered from, and no process's memory creeps up.
This module holds the logic only (no ROS, no processes, no sockets), so that it is tested
offline; bench/soak.py runs the stack, applies the faults and feeds what it sees here.

- `make_schedule()`: the faults of a soak from a seed (same seed, same schedule): link cuts both
  ways shorter and longer than conn/timeout, bursts of 10-30 % loss, a bridge and a simulator
  killed, junk floods at the bridge's and the simulator's ports; the kinds come in shuffled
  rounds, so every kind is done once before any is done again.
- `Monitor` / `FaultWatch`: what each fault did (modes seen, disarmed, disconnected, lowest
  altitude), and its recovery: the first moment after the fault ended at which the vehicle is
  connected, in OFFBOARD, armed and within 0.2 m of 2 m, on messages received after the end
  (so the last state a killed bridge published does not count). Between faults, any loss of
  hover (a "lapse") is recorded.
- `rss_growth()`: RSS of each process (each incarnation of a respawned one) one minute after
  it was first seen, and at the end; more than 2 MB of growth fails.

Times are simulated seconds since the soak started.
"""

import collections
import random
import threading

TARGET_Z_M = 2.0
RECOVERY_TOLERANCE_M = 0.2
# A fault is recovered within this many simulated seconds after it ended, or the soak fails. The
# slowest recovery by design is the simulator's restart: respawned 5 s later, pre-flight checks
# 5 s, connection, then the node's requests 5 s apart (OFFBOARD, arm) and the 7 s climb: about
# 30 s. A long cut ends with the vehicle landed or landing: about 20 s. The bound is 3 x that.
RECOVERY_BOUND_S = 90.0
# Hover held at least this long before the next fault: each fault starts from a steady hover, and
# offb_node's count of quick disarms (QUICK_DISARM_S, 30 s armed) has been reset.
SETTLE_S = 40.0
# Out of hover between faults: not OFFBOARD, disarmed, disconnected, or further than this from 2 m.
LAPSE_M = 0.5
FIRST_FAULT_S = 90.0        # planned start of the first fault (after the first minute of RSS)
GAP_S = (60.0, 100.0)       # hover planned between one fault's end and the next's start
TAIL_S = 60.0               # no fault planned in the last minute of the soak
FIRST_MINUTE_S = 60.0
RSS_LIMIT_MB = 2.0

CUT_SHORT, CUT_LONG, LOSS_BURST = 'cut_short', 'cut_long', 'loss_burst'
BRIDGE_KILL, SIM_KILL, JUNK_BRIDGE, JUNK_SIM = 'bridge_kill', 'sim_kill', 'junk_bridge', 'junk_sim'
KINDS = (CUT_SHORT, CUT_LONG, LOSS_BURST, BRIDGE_KILL, SIM_KILL, JUNK_BRIDGE, JUNK_SIM)
LOSS_RANGE = (0.10, 0.30)
LOSS_SECONDS = (10.0, 60.0)
JUNK_DATAGRAMS = (2000, 8000)
MIN_CONN_TIMEOUT_S = 3.0  # a cut shorter than conn/timeout must still outlast COM_OF_LOSS_T (1 s)


class Fault(collections.namedtuple('Fault', 'index kind at_s seconds drop datagrams seed what')):
    """One fault of the schedule: planned start at_s, length `seconds` (cuts and loss bursts; 0 for
    the others), loss probability `drop` (bursts), `datagrams` and their `seed` (junk floods), and
    `what` it is, in words."""

    def as_dict(self):
        return dict(self._asdict())


def make_schedule(seed, minutes, conn_timeout_s, first_at_s=FIRST_FAULT_S, gap_s=GAP_S, tail_s=TAIL_S):
    """The faults of a soak of `minutes` simulated minutes, from `seed`. Raises ValueError naming a bad input."""
    if not isinstance(seed, int):
        raise ValueError('seed must be a whole number, got %r' % (seed,))
    if not minutes > 0:
        raise ValueError('minutes must be above 0, got %r' % (minutes,))
    if not conn_timeout_s >= MIN_CONN_TIMEOUT_S:
        raise ValueError('conn/timeout must be at least %g s (a short cut must outlast COM_OF_LOSS_T), got %r'
                         % (MIN_CONN_TIMEOUT_S, conn_timeout_s))
    rng = random.Random(seed)
    faults, kinds = [], []
    t = first_at_s
    while t <= minutes * 60.0 - tail_s:
        if not kinds:
            kinds = rng.sample(KINDS, len(KINDS))
        kind = kinds.pop(0)
        seconds, drop, datagrams, junk_seed = 0.0, 0.0, 0, 0
        if kind == CUT_SHORT:
            seconds = round(rng.uniform(1.5, conn_timeout_s - 1.0), 1)
            what = 'link cut both ways for %.1f s (< conn/timeout %g s)' % (seconds, conn_timeout_s)
        elif kind == CUT_LONG:
            seconds = round(rng.uniform(conn_timeout_s + 2.0, conn_timeout_s + 16.0), 1)
            what = 'link cut both ways for %.1f s (> conn/timeout %g s)' % (seconds, conn_timeout_s)
        elif kind == LOSS_BURST:
            drop = round(rng.uniform(*LOSS_RANGE), 2)
            seconds = round(rng.uniform(*LOSS_SECONDS), 1)
            what = '%.0f %% loss both ways for %.1f s' % (100 * drop, seconds)
        elif kind in (JUNK_BRIDGE, JUNK_SIM):
            datagrams = rng.randint(*JUNK_DATAGRAMS)
            junk_seed = rng.randrange(2 ** 31)
            what = '%d junk datagrams at the %s\'s port' % (datagrams, 'bridge' if kind == JUNK_BRIDGE else 'simulator')
        else:
            what = '%s killed (SIGKILL), respawned' % ('bridge' if kind == BRIDGE_KILL else 'simulator')
        faults.append(Fault(len(faults) + 1, kind, round(t, 1), seconds, drop, datagrams, junk_seed, what))
        t += seconds + rng.uniform(*gap_s)
    return faults


def in_hover(connected, mode, armed, z, target_z_m=TARGET_Z_M, tolerance_m=RECOVERY_TOLERANCE_M):
    return bool(connected and armed and mode == 'OFFBOARD' and z is not None
                and abs(z - target_z_m) <= tolerance_m + 1e-9)  # 2.2 m is within 0.2 m of 2 m


class FaultWatch:
    """One fault as the vehicle lived it: its effects from start_s until recovery, and the recovery.

    `end(t)` marks the end of the fault (a cut or burst over, a respawned process back, a flood
    sent). It is recovered at the first pose after the end that is within tolerance while the
    latest state, itself received after the end, is connected, OFFBOARD and armed. Poses come at
    30 Hz, states on each change and each HEARTBEAT (1 Hz): so a fault that changed nothing is
    recovered within about a second of its end.
    """

    def __init__(self, fault, start_s, bound_s=RECOVERY_BOUND_S):
        self.fault, self.start_s, self.bound_s = fault, start_s, bound_s
        self.end_s = None
        self.recovered_s = None
        self.error = None          # why the fault could not be done or ended (then it is not recovered)
        self.modes = []            # modes other than OFFBOARD seen while connected, in order
        self.disarmed = False
        self.disconnected = False
        self.lowest_z = None
        self._state = None         # (connected, mode, armed) of the latest state received after the end

    def end(self, t):
        if self.end_s is None:
            self.end_s = t

    def on_state(self, t, connected, mode, armed):
        if t < self.start_s or self.recovered_s is not None:
            return
        if not connected:
            self.disconnected = True
        else:
            if mode != 'OFFBOARD' and mode not in self.modes:
                self.modes.append(mode or 'unknown')
            if not armed:
                self.disarmed = True
        if self.end_s is not None and t >= self.end_s:
            self._state = (connected, mode, armed)

    def on_pose(self, t, z):
        if t < self.start_s or self.recovered_s is not None:
            return
        self.lowest_z = z if self.lowest_z is None else min(self.lowest_z, z)
        if self.end_s is not None and t >= self.end_s and self._state is not None and in_hover(*self._state, z=z):
            self.recovered_s = t

    @property
    def recovered(self):
        return self.recovered_s is not None and self.error is None

    @property
    def recovery_s(self):
        """Seconds from the end of the fault to hover again (None until then)."""
        return None if self.recovered_s is None or self.end_s is None else self.recovered_s - self.end_s

    @property
    def outage_s(self):
        """Seconds from the start of the fault to hover again."""
        return None if self.recovered_s is None else self.recovered_s - self.start_s

    def overdue(self, now_s):
        """True when the fault ended more than bound_s ago and hover is not back."""
        return self.recovered_s is None and self.end_s is not None and now_s - self.end_s > self.bound_s

    def effect(self):
        """What the fault did to the vehicle, in a few words."""
        parts = list(self.modes)
        if self.disarmed:
            parts.append('disarmed')
        if self.disconnected:
            parts.append('disconnected')
        if not parts:
            parts.append('stayed OFFBOARD, armed')
        if self.lowest_z is not None:
            parts.append('lowest z %.2f m' % self.lowest_z)
        return ', '.join(parts)

    def as_dict(self):
        return {'fault': self.fault.as_dict() if self.fault else None, 'start_s': self.start_s,
                'end_s': self.end_s, 'recovered_s': self.recovered_s, 'recovery_s': self.recovery_s,
                'outage_s': self.outage_s, 'recovered': self.recovered, 'error': self.error,
                'modes': self.modes, 'disarmed': self.disarmed, 'disconnected': self.disconnected,
                'lowest_z_m': self.lowest_z, 'effect': self.effect(), 'bound_s': self.bound_s}


class Monitor:
    """Everything the vehicle showed during the soak (fed from the ROS callbacks' threads), the
    watch of the fault under way, and the lapses: spells out of hover while no fault was under way.

    The start-up is watched like a fault that ended at time 0: hover begins when it is recovered.
    """

    def __init__(self, lapse_m=LAPSE_M):
        self.lock = threading.Lock()
        self.lapse_m = lapse_m
        self.states = []            # (t, connected, mode, armed)
        self.poses = []             # (t, z)
        self.watches = []           # FaultWatch of each fault done, in order
        self.startup = FaultWatch(None, 0.0)
        self.startup.end(0.0)
        self.current = self.startup
        self.lapses = []            # (t, what) at the start of each spell out of hover between faults
        self.hover_since = None     # start of the current spell in hover between faults
        self.state = (False, '', False)
        self.z = None
        self.z_s = None             # when the latest altitude came

    def on_state(self, t, connected, mode, armed):
        with self.lock:
            self.states.append((t, connected, mode, armed))
            self.state = (connected, mode, armed)
            if self.current is not None:
                self.current.on_state(t, connected, mode, armed)
            self._after(t)

    def on_pose(self, t, z):
        with self.lock:
            self.poses.append((t, z))
            self.z, self.z_s = z, t
            if self.current is not None:
                self.current.on_pose(t, z)
            self._after(t)

    def _after(self, t):
        """Hover watching: from a fault's recovery until the next fault."""
        if self.current is not None:
            if self.current.recovered_s is None:
                return
            self.current = None
            self.hover_since = t
            return
        connected, mode, armed = self.state
        out = self._out_of_hover(connected, mode, armed, self.z)
        if out and self.hover_since is not None:
            self.lapses.append((t, out))
            self.hover_since = None
        elif not out and self.hover_since is None:
            self.hover_since = t

    def _out_of_hover(self, connected, mode, armed, z):
        if not connected:
            return 'disconnected'
        if mode != 'OFFBOARD':
            return 'mode %s' % (mode or 'unknown')
        if not armed:
            return 'disarmed'
        if z is None or abs(z - TARGET_Z_M) > self.lapse_m:
            return 'z %.2f m' % z if z is not None else 'no altitude'
        return None

    def begin(self, fault, t, bound_s=RECOVERY_BOUND_S):
        """A fault starts now: watch it (the previous one must be recovered)."""
        with self.lock:
            watch = FaultWatch(fault, t, bound_s)
            self.watches.append(watch)
            self.current = watch
            self.hover_since = None
            return watch

    def hover_held_s(self, now_s):
        """Seconds the vehicle has been in hover with no fault under way (0 if not)."""
        with self.lock:
            return 0.0 if self.current is not None or self.hover_since is None else now_s - self.hover_since

    def snapshot(self):
        """The latest state (connected, mode, armed), the latest altitude and when it came."""
        with self.lock:
            return self.state, self.z, self.z_s


def rss_growth(samples, first_minute_s=FIRST_MINUTE_S, limit_mb=RSS_LIMIT_MB):
    """RSS growth of each process after its first minute, from samples (t_s, role, pid, rss_mb).

    One row per process in order of appearance (a respawned process is a new one): its RSS at
    the first sample at least first_minute_s after it was first seen (the baseline) and at its
    last sample. A process seen for less than that is not judged; one that grew more than
    limit_mb is not ok.
    """
    rows = collections.OrderedDict()
    for t, role, pid, rss in sorted(samples, key=lambda s: s[0]):
        if rss is None:
            continue
        row = rows.setdefault((role, pid), {'role': role, 'pid': pid, 'first_s': t, 'baseline_s': None,
                                            'baseline_mb': None, 'last_s': t, 'last_mb': rss, 'peak_mb': rss})
        if row['baseline_s'] is None and t - row['first_s'] >= first_minute_s:
            row['baseline_s'], row['baseline_mb'] = t, rss
        row['last_s'], row['last_mb'], row['peak_mb'] = t, rss, max(row['peak_mb'], rss)
    out = []
    for row in rows.values():
        judged = row['baseline_mb'] is not None
        row['growth_mb'] = row['last_mb'] - row['baseline_mb'] if judged else None
        row['judged'] = judged
        row['ok'] = not judged or row['growth_mb'] <= limit_mb
        out.append(row)
    return out


def verdict(watches, rss_rows, lapses, stopped=None, startup=None, limit_mb=RSS_LIMIT_MB):
    """The reasons the soak failed (empty: it passed)."""
    reasons = []
    if startup is not None and startup.recovered_s is None:
        reasons.append('no hover after start-up: %s' % (startup.error or 'never OFFBOARD, armed at 2 m'))
    for w in watches:
        if not w.recovered:
            reasons.append('fault %d (%s) not recovered: %s' % (
                w.fault.index, w.fault.what, w.error or 'not back in hover within %.0f s of its end' % w.bound_s))
    for row in rss_rows:
        if not row['ok']:
            reasons.append('%s (pid %d) RSS grew %.1f MB after its first minute (%.1f -> %.1f MB; limit %.0f MB)'
                           % (row['role'], row['pid'], row['growth_mb'], row['baseline_mb'], row['last_mb'], limit_mb))
    if lapses:
        reasons.append('hover lost %d time(s) with no fault under way (first at %.1f s: %s)'
                       % (len(lapses), lapses[0][0], lapses[0][1]))
    if stopped:
        reasons.append(stopped)
    return reasons


def _fmt(value, digits=1):
    return '-' if value is None else '%.*f' % (digits, value)


def fault_table(watches):
    lines = ['| # | fault | at (s) | ended (s) | effect | recovered after (s) | outage (s) | recovered |',
             '|---|---|---|---|---|---|---|---|']
    for w in watches:
        lines.append('| %d | %s | %s | %s | %s | %s | %s | %s |' % (
            w.fault.index, w.fault.what, _fmt(w.start_s), _fmt(w.end_s), w.effect(), _fmt(w.recovery_s),
            _fmt(w.outage_s), 'yes' if w.recovered else '**NO**%s' % (': ' + w.error if w.error else '')))
    return lines


def rss_table(rows, limit_mb=RSS_LIMIT_MB):
    lines = ['| process | pid | seen (s) | RSS after 1 min (MB) | RSS at end (MB) | growth (MB) | within %.0f MB |'
             % limit_mb, '|---|---|---|---|---|---|---|']
    for r in rows:
        lines.append('| %s | %d | %s-%s | %s | %s | %s | %s |' % (
            r['role'], r['pid'], _fmt(r['first_s'], 0), _fmt(r['last_s'], 0), _fmt(r['baseline_mb']),
            _fmt(r['last_mb']), '%+.1f' % r['growth_mb'] if r['judged'] else '-',
            ('yes' if r['ok'] else '**NO**') if r['judged'] else 'not judged (seen < 1 min)'))
    return lines
