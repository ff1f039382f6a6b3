"""The governed clock: simulated time that runs at up to `speed` x the wall clock and never further ahead of
its slowest participant than a lead, so a process starved of CPU slows or pauses the run instead of missing a
simulated deadline.

One small shared file per run (the board, in /dev/shm) holds the clock and a slot per participant:

    sim_s = min(base_sim + speed * (monotonic - base_mono), horizon)

Every process of the run reads the clock from the board (offboard_py.simtime.SimClock). Each participant (a
simulated PX4, a bridge, a test node, a test's MAVLink client, the relay) writes into its slot how far it has
got (the simulated time it last read and worked at) and when (the monotonic clock). The governor (sim_clock,
or the pytest plugin's thread for the simulator tier) moves the horizon to the slowest live participant's
progress + the lead, 100 times a wall second; when the clock had reached the old horizon it first moves the
base there, so the clock goes on from where it stopped, never jumps and never runs backwards. A governor that
is itself starved stops the clock at the horizon: a busy machine makes the run slower, not wrong.

PX4 SITL's lockstep has its simulator wait for PX4's actuator outputs (HIL_ACTUATOR_CONTROLS) before the next
sensor step; Gazebo's real-time factor only caps the speed. Here every participant counts, ROS nodes too, and
none has to answer each step: the lead (0.03 wall seconds at the run's speed) is what the fastest may
run ahead of the slowest.

A participant whose progress has not moved on for STALE_WALL_S wall seconds (10: a process stopped, or stuck,
or a clock held that long for anyone) is left out, and that is reported; a slot whose process has ended is freed. Every hold longer than a
tenth of a wall second is counted with the participant that held it (`holds()`), so a run can say where its
time went. No ROS, no MAVLink here.
"""

import fcntl
import mmap
import os
import re
import struct
import threading
import time

BOARD_ENV = 'OFFBOARD_PY_CLOCK_BOARD'
BOARD_DIR = '/dev/shm' if os.path.isdir('/dev/shm') else '/tmp'
MAGIC = b'OBPYCLK1'
SLOTS = 64
NAME_BYTES = 40
# how far (wall seconds at the speed) the clock may run ahead of the slowest participant: a bridge's timer runs at
# most this late (0.06 s simulated at 2x, within the conversation's 10 % of its 1 s version request)
LEAD_WALL_S = 0.03
# a participant silent this long (wall) is left out of the governing: longer than a starved process stays off the
# CPU on a loaded machine (at 2, a test node stopped for 3 s lost its vehicle the offboard signal, as two loaded
# runs' squares did)
STALE_WALL_S = 10.0
HOLD_REPORT_WALL_S = 0.1  # holds longer than this are counted
READ_TRIES = 10000        # reads of a header being written before it is taken as it stands

# header: magic, seq, speed, base_mono, base_sim, horizon, governor pid, hold count, held wall s, when the hold
# under way began (0: none), when the last hold began, last holder
_HEADER = struct.Struct('<8sQddddiIddd%ds' % NAME_BYTES)
_NAMES = ('magic', 'seq', 'speed', 'base_mono', 'base_sim', 'horizon', 'governor', 'holds', 'held_s', 'hold_started',
          'held_from', 'holder')
# slot: seq, pid, progress (simulated s), updated (monotonic s), name
_SLOT = struct.Struct('<Qiidd%ds' % NAME_BYTES)
_SIZE = _HEADER.size + SLOTS * _SLOT.size


class BoardError(Exception):
    """A board file that cannot be used; the message names it."""


def board_path(speed, environ=os.environ):
    """The board of this run, or None (no governing: simulated time is speed x the monotonic clock).

    $OFFBOARD_PY_CLOCK_BOARD when set (the simulator tier sets it for its processes; empty: none); else, in
    simulated time (speed != 1) under a ROS master, one board per master: every process a roslaunch starts
    has ROS_MASTER_URI, so the simulators, the bridges and the test nodes of a rostest meet on it."""
    if BOARD_ENV in environ:
        return environ[BOARD_ENV] or None
    master = environ.get('ROS_MASTER_URI', '')
    if speed == 1.0 or not master:
        return None
    return os.path.join(BOARD_DIR, 'offboard_py-clock-%s' % re.sub(r'[^A-Za-z0-9]+', '_', master).strip('_'))


def pid_alive(pid):
    """True while a process `pid` runs (a process of another user's counts)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


LEFT_OVER_S = 3600.0  # a board untouched this long (mtime) whose processes have all ended is what a killed run left


def sweep(directory=BOARD_DIR, older_than_s=LEFT_OVER_S, now=time.time):
    """Remove the boards that runs killed before their governor could remove them: untouched for older_than_s,
    and no process of theirs alive (a run that merely started long ago keeps its board). Returns their paths."""
    removed = []
    try:
        names = os.listdir(directory)
    except OSError:
        return removed
    for name in names:
        path = os.path.join(directory, name)
        if not name.startswith('offboard_py-clock-'):
            continue
        try:
            if now() - os.stat(path).st_mtime < older_than_s:
                continue
            with open(path, 'rb') as f:
                data = f.read(_SIZE + 1)
            if len(data) == _SIZE and data[:8] == MAGIC:
                pids = [_HEADER.unpack(data[:_HEADER.size])[6]] + [
                    _SLOT.unpack_from(data, _HEADER.size + i * _SLOT.size)[1] for i in range(SLOTS)]
                if any(pid_alive(pid) for pid in pids):
                    continue
            os.unlink(path)
            removed.append(path)
        except OSError:  # another process swept it, or it is not ours to remove
            continue
    return removed


class Board:
    """One run's board, opened (and made, by the first process to come) at `path`."""

    def __init__(self, path, speed, monotonic=time.monotonic):
        self.path = path
        self._monotonic = monotonic
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as err:
            raise BoardError('clock board %s: %s' % (path, err.strerror)) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            try:
                made = os.fstat(fd).st_size != _SIZE
                try:
                    if made:
                        os.ftruncate(fd, _SIZE)
                    self._map = mmap.mmap(fd, _SIZE)
                except OSError as err:  # a full /dev/shm, a file of another kind
                    raise BoardError('clock board %s: %s' % (path, err.strerror or err)) from None
                header = None if made else self._read_header()
                if header is None or header[0] != MAGIC or not self._governor_or_participants_alive(header):
                    self._init(speed)  # a new run (or what a run that has ended left)
                elif header[2] != speed:
                    raise BoardError('clock board %s runs at %gx, not %gx: one speed for every process of a run'
                                     % (path, header[2], speed))
            finally:
                fcntl.flock(fd, fcntl.LOCK_UN)
        finally:
            os.close(fd)
        self.speed = speed
        self.lead_s = LEAD_WALL_S * speed
        # the latest time now() gave in this process: it never gives less (see now())
        self._given_s, self._given_lock = float('-inf'), threading.Lock()

    # -- the clock, for every reader ----------------------------------------------------------------------

    def _read_header(self):
        """The header as one write left it. A write is one copy of a few dozen bytes, so a torn read is read
        again; a writer that died inside one (its count left odd) is not waited for past READ_TRIES."""
        for _ in range(READ_TRIES):
            raw = self._map[:_HEADER.size]
            fields = _HEADER.unpack(raw)
            if fields[1] % 2 == 0 and self._map[8:16] == raw[8:16]:
                return fields
        return _HEADER.unpack(self._map[:_HEADER.size])

    def _write_header(self, **changes):
        fields = list(_HEADER.unpack(self._map[:_HEADER.size]))
        seq = fields[1]
        self._map[8:16] = struct.pack('<Q', seq + 1)  # odd: a write under way
        for name, value in changes.items():
            fields[_NAMES.index(name)] = value
        fields[1] = seq + 1
        self._map[:_HEADER.size] = _HEADER.pack(*fields)
        self._map[8:16] = struct.pack('<Q', seq + 2)

    def _init(self, speed):
        now = self._monotonic()
        self._map[:] = bytes(_SIZE)
        self._map[:_HEADER.size] = _HEADER.pack(MAGIC, 0, speed, now, speed * now, float('inf'), 0, 0, 0.0, 0.0,
                                                0.0, b'')

    def _governor_or_participants_alive(self, header):
        return pid_alive(header[6]) or any(pid_alive(slot[1]) for slot in self._slots())

    def now(self):
        """Simulated seconds: speed x the monotonic clock since the base, held at the horizon; never less than
        this process read before. The governor computes a horizon from a clock it read a moment before it
        writes it, and a reader in between may have read past it (by the milliseconds a governor thread waits
        for the GIL, or is preempted): the clock then stands for that reader until it catches up, and a
        kernel stamp taken on it (at()) is never after a now() read later."""
        _, _, speed, base_mono, base_sim, horizon = self._read_header()[:6]
        sim_s = min(base_sim + speed * (self._monotonic() - base_mono), horizon)
        with self._given_lock:
            if sim_s < self._given_s:
                return self._given_s
            self._given_s = sim_s
        return sim_s

    def at(self, mono_s):
        """The simulated time the clock read at the monotonic instant mono_s (a kernel's receive stamp, in the
        past): from the base on, the clock; back to the start of the last hold, the held time; before that, as
        if it had run up to the hold. Never after now()."""
        header = self._read_header()
        speed, base_mono, base_sim, horizon, held_from = header[2], header[3], header[4], header[5], header[10]
        if mono_s >= base_mono:
            at_s = min(base_sim + speed * (mono_s - base_mono), horizon)
        elif held_from and mono_s >= held_from:
            at_s = base_sim
        else:
            at_s = base_sim - speed * ((held_from or base_mono) - mono_s)
        return min(at_s, self.now())

    def held(self):
        """True while the clock stands at its horizon (it waits for a participant)."""
        _, _, speed, base_mono, base_sim, horizon = self._read_header()[:6]
        return base_sim + speed * (self._monotonic() - base_mono) >= horizon

    # -- participants --------------------------------------------------------------------------------------

    def _slots(self):
        for i in range(SLOTS):
            offset = _HEADER.size + i * _SLOT.size
            raw = self._map[offset:offset + _SLOT.size]
            while raw != self._map[offset:offset + _SLOT.size]:  # its owner wrote meanwhile: read it again
                raw = self._map[offset:offset + _SLOT.size]
            yield (i,) + _SLOT.unpack(raw)[1:]

    def join(self, name):
        """A Participant slot for this process under `name`."""
        fd = os.open(self.path, os.O_RDWR)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            try:
                for i, pid, _, _, _, _ in self._slots():
                    if pid == 0 or not pid_alive(pid):
                        participant = Participant(self, i, name)
                        participant.update(self.now())
                        return participant
            finally:
                fcntl.flock(fd, fcntl.LOCK_UN)
        finally:
            os.close(fd)
        raise BoardError('clock board %s: all %d participant slots are taken' % (self.path, SLOTS))

    def participants(self):
        """[(name, pid, progress_s, updated_mono)] of the slots in use by live processes."""
        out = []
        for _, pid, _, progress, updated, name in self._slots():
            if pid and pid_alive(pid):
                out.append((name.rstrip(b'\0').decode(errors='replace'), pid, progress, updated))
        return out

    # -- the governor --------------------------------------------------------------------------------------

    def govern(self):
        """One governing step: the horizon to the slowest live, fresh participant + the lead. Returns
        (the participant that holds the clock now or None, the names left out as stale)."""
        now_mono = self._monotonic()
        header = self._read_header()
        _, _, speed, base_mono, base_sim, horizon = header[:6]
        holds, held_s, hold_started = header[7], header[8], header[9]
        running = base_sim + speed * (now_mono - base_mono)
        live = self.participants()
        fresh = [(progress, name) for name, _, progress, updated in live if now_mono - updated <= STALE_WALL_S]
        stale = [name for name, _, _, updated in live if now_mono - updated > STALE_WALL_S]
        changes = {'governor': os.getpid()}
        slowest = min(fresh) if fresh else None
        clock_s = min(running, horizon)
        if running >= horizon:
            # held: go on from the horizon, not from where the formula got to meanwhile
            changes.update(base_mono=now_mono, base_sim=horizon)
        new_horizon = max(clock_s, slowest[0] + self.lead_s) if slowest else float('inf')
        if horizon != float('inf'):
            # granted: a reader may have read the clock up to it, so it is never taken back (a participant
            # that reports less than before, the bridge's limit, one that joins behind, a stale one back)
            new_horizon = max(new_horizon, horizon)
        elif new_horizon != float('inf'):
            # the first participant: down to where the clock is as this step writes, not where it was at its
            # first look (it ran on meanwhile, and a reader may have read it)
            new_horizon = max(new_horizon, base_sim + speed * (self._monotonic() - base_mono))
        changes['horizon'] = new_horizon
        waiting = slowest is not None and running >= horizon
        if waiting and not hold_started:  # held since the clock reached the horizon, not since this step saw it
            reached = min(now_mono, base_mono + (horizon - base_sim) / speed)
            changes.update(hold_started=reached, held_from=reached, holder=slowest[1].encode()[:NAME_BYTES])
        elif not waiting and hold_started:
            if now_mono - hold_started > HOLD_REPORT_WALL_S:
                changes.update(holds=holds + 1, held_s=held_s + now_mono - hold_started)
            changes.update(hold_started=0.0)
        self._write_header(**changes)
        return (slowest[1] if waiting else None), stale

    def holds(self):
        """(how many holds over HOLD_REPORT_WALL_S, their wall seconds in all, the last holder's name)."""
        header = self._read_header()
        return header[7], header[8], header[11].rstrip(b'\0').decode(errors='replace')

    def close(self):
        self._map.close()


class ThreadParticipant:
    """A participant whose keeping up is that it gets the CPU (a test's MAVLink client, the relay): a daemon
    thread writes progress() into its slot every UPDATE_WALL_S until leave(). A periodic sender of the process
    (a ground station's joystick, a setpoint stream) says when its next send is due (due()), and the slot stays
    no further than the earliest: a sender the CPU left behind holds the clock, so PX4 does not count its
    MANUAL_CONTROL or setpoints lost while the thread that reports the process keeps running."""

    UPDATE_WALL_S = 0.01

    def __init__(self, board, name):
        self.participant = board.join(name)
        self.board, self.running = board, True
        self._dues, self._lock = {}, threading.Lock()
        self.thread = threading.Thread(target=self._run, name='clock participant', daemon=True)
        self.thread.start()

    def due(self, sender, sim_s):
        """`sender`'s next send is due at sim_s (simulated s); None: it has stopped sending."""
        with self._lock:
            if sim_s is None:
                self._dues.pop(sender, None)
            else:
                self._dues[sender] = sim_s

    def progress(self):
        """The clock, or the earliest send due, if earlier."""
        with self._lock:
            return min([self.board.now()] + list(self._dues.values()))

    def _run(self):
        while self.running:
            self.participant.update(self.progress())
            time.sleep(self.UPDATE_WALL_S)
        self.participant.leave()

    def leave(self):
        self.running = False


class GovernorThread:
    """Governs a board from a daemon thread of this process (the simulator tier's pytest process) until stop()."""

    PERIOD_WALL_S = 0.01

    def __init__(self, board):
        self.board, self.running = board, True
        self.thread = threading.Thread(target=self._run, name='clock governor', daemon=True)
        self.thread.start()

    def _run(self):
        while self.running:
            self.board.govern()
            time.sleep(self.PERIOD_WALL_S)

    def stop(self):
        self.running = False
        self.thread.join(1.0)


class Participant:
    """One slot of the board: update(progress_s) says how far this participant has got. The slot's time is when
    its progress last moved on: a participant that keeps writing the same progress is as stale as a silent
    one after STALE_WALL_S, so no hold lasts longer, whatever holds it (a stopped process, a clock that
    runs behind on purpose, a deadlock)."""

    def __init__(self, board, index, name):
        self.board, self.offset = board, _HEADER.size + index * _SLOT.size
        self.name = name.encode()[:NAME_BYTES]
        self.seq = 0
        self.pid = os.getpid()
        self.progress_s, self.moved_mono = float('-inf'), board._monotonic()

    def update(self, progress_s):
        self.seq += 1
        if progress_s > self.progress_s:
            self.progress_s, self.moved_mono = progress_s, self.board._monotonic()
        self.board._map[self.offset:self.offset + _SLOT.size] = _SLOT.pack(
            self.seq, self.pid, 0, progress_s, self.moved_mono, self.name)

    def leave(self):
        self.board._map[self.offset:self.offset + _SLOT.size] = bytes(_SLOT.size)
