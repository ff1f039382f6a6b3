"""The governed clock's board (offboard_py.clock_board), on a clock of the test's own: the formula while every
participant keeps up, held at the slowest participant + the lead, going on from there without a jump, the
stale and the ended left out, the holds counted with who held them."""

import os
import select
import subprocess
import sys
import time

import pytest

from offboard_py import clock_board
from offboard_py.clock_board import Board, BoardError
from offboard_py.simtime import SimClock

SLEEPER_START_S = 30.0  # wall seconds a sleeper process may take to start, and then to be seen asleep


class Wall:
    def __init__(self, t=100.0):
        self.t = t

    def __call__(self):
        return self.t


@pytest.fixture
def wall():
    return Wall()


def board_at(tmp_path, wall, speed=5.0, name='b'):
    return Board(str(tmp_path / name), speed, monotonic=wall)


def test_without_participants_the_clock_is_the_formula(tmp_path, wall):
    board = board_at(tmp_path, wall)
    assert board.now() == pytest.approx(500.0)
    board.govern()
    wall.t += 1.0
    assert board.now() == pytest.approx(505.0) and not board.held()


def test_a_lagging_participant_holds_the_clock_and_it_goes_on_without_a_jump(tmp_path, wall):
    board = board_at(tmp_path, wall)
    slow, fast = board.join('slow'), board.join('fast')
    lead = board.lead_s
    assert lead == pytest.approx(0.15), '0.03 wall seconds at 5x'
    board.govern()
    wall.t += 0.2                       # 1 s of simulated time; the slow one does not move
    fast.update(board.now())
    assert board.now() == pytest.approx(500.0 + lead), 'held at the slow one + the lead'
    holder, stale = board.govern()
    assert holder == 'slow' and stale == [] and board.held()
    wall.t += 0.5
    assert board.now() == pytest.approx(500.0 + lead), 'still held: 0.5 wall seconds later'
    slow.update(board.now())            # the slow one catches up
    fast.update(board.now())
    board.govern()
    wall.t += 0.01
    assert board.now() == pytest.approx(500.0 + lead + 0.05), 'on from where it stood, at 5x'
    board.govern()                      # the next step finds it running: the hold is over
    count, held_s, last = board.holds()
    assert count == 1 and held_s > 0.1 and last == 'slow'


def test_a_granted_horizon_is_never_taken_back(tmp_path, wall):
    """A participant that reports less than it did (the bridge's limit: a task due in the past), or one that
    joins behind, holds the clock where the horizon stands: a reader may have read up to it, and the clock
    going back would take every process back with it (rospy's Rate.sleep raises on it)."""
    board = board_at(tmp_path, wall)
    p = board.join('p')
    board.govern()
    granted = board.now() + board.lead_s
    wall.t += 0.01  # 0.05 s of the lead run
    p.update(board.now() - 1.0)  # a limit 1 s back
    board.govern()
    wall.t += 0.1
    other = Board(board.path, 5.0, monotonic=wall)  # a reader with no reading of its own yet
    assert other.now() == pytest.approx(granted), 'held at the horizon granted, not 1 s back'


def test_the_first_participant_holds_the_clock_where_it_stands_at_the_write(tmp_path, wall):
    """With no participant the clock runs free; the first holds it where it stands when the horizon is written,
    not where it stood at the governor's first look: a reader in between (another thread while the governor
    waits for the GIL, another process while it is preempted) has seen it run on."""
    board, reader = board_at(tmp_path, wall), board_at(tmp_path, wall)
    board.govern()
    p = board.join('p')
    p.update(board.now() - 1.0)  # joined 1 s behind (a process that read the clock, then waited for the CPU)
    seen = []
    looked = board.participants

    def participants():
        wall.t += 0.004  # the governor off the CPU for 4 ms between its look at the clock and its write
        seen.append(reader.now())
        return looked()

    board.participants = participants
    board.govern()
    wall.t += 0.1
    after = Board(board.path, 5.0, monotonic=wall).now()  # a reader with no reading of its own
    assert after == pytest.approx(seen[0]), 'held where it stood at the write (%.3f), not %.3f' % (seen[0], after)


def test_a_process_never_reads_less_than_it_read_before(tmp_path, wall):
    """Whatever a header says, now() in one process does not go back (a board written by a governor that
    was preempted between its look and its write): it stands until the clock gets there."""
    board, governor = board_at(tmp_path, wall), board_at(tmp_path, wall)
    before = board.now()
    governor._write_header(horizon=before - 0.5)
    assert board.now() == before, 'stands at what it read'
    assert governor.now() == pytest.approx(before - 0.5), 'a fresh reader reads the header'
    governor._write_header(horizon=float('inf'))
    wall.t += 0.2
    assert board.now() == pytest.approx(before + 1.0)


def test_the_clock_never_runs_backwards(tmp_path, wall):
    board = board_at(tmp_path, wall)
    p = board.join('p')
    readings = []
    for step in range(200):
        wall.t += 0.003
        if step % 7:
            p.update(board.now() - 0.1)   # sometimes behind, sometimes not at all
        board.govern()
        readings.append(board.now())
    assert readings == sorted(readings)


def assert_left_out_and_running(board, wall, governed):
    """'stuck' is named stale, holds nothing, and the clock runs again at the speed."""
    holder, stale = governed
    assert stale == ['stuck'] and holder is None
    start = board.now()
    wall.t += 0.1
    assert board.now() == pytest.approx(start + 0.5), 'runs again without the stale one'


def test_a_stale_participant_is_left_out_and_named(tmp_path, wall):
    board = board_at(tmp_path, wall)
    board.join('stuck')
    board.govern()
    wall.t += clock_board.STALE_WALL_S + 0.1
    assert_left_out_and_running(board, wall, board.govern())


def test_a_slot_of_an_ended_process_is_freed(tmp_path, wall):
    path = str(tmp_path / 'b')
    board_at(tmp_path, wall)
    script = ('import sys, time; sys.path[:0] = %r\nfrom offboard_py.clock_board import Board\n'
              'Board(%r, 5.0).join("child").update(1.0)\n' % (sys.path, path))
    subprocess.run([sys.executable, '-c', script], check=True, timeout=60)
    board = board_at(tmp_path, wall)
    assert [name for name, _, _, _ in board.participants()] == [], 'the child has ended'
    board.join('me')
    assert [name for name, pid, _, _ in board.participants()] == ['me']


def test_one_speed_for_every_process_of_a_run(tmp_path, wall):
    board = board_at(tmp_path, wall)
    board.join('alive')
    with pytest.raises(BoardError, match='runs at 5x, not 2x'):
        Board(board.path, 2.0, monotonic=wall)


def test_a_board_left_by_an_ended_run_is_made_new(tmp_path, wall):
    board = board_at(tmp_path, wall, speed=2.0)
    board.join('gone').leave()
    assert Board(board.path, 5.0, monotonic=wall).speed == 5.0, 'nobody alive on it: a new run, any speed'


def test_arrival_stamps_are_never_after_now(tmp_path, wall):
    board = board_at(tmp_path, wall)
    board.join('slow')
    board.govern()
    wall.t += 1.0
    board.govern()
    assert board.at(wall.t - 0.01) <= board.now()
    assert board.at(wall.t - 0.9) == pytest.approx(500.0 + board.lead_s), 'held then'
    assert board.at(wall.t - 1.0 - 0.01) == pytest.approx(500.0 - 0.05), 'before the hold: the clock as it ran'


def test_board_path_per_master_only_in_simulated_time():
    env = {'ROS_MASTER_URI': 'http://localhost:11312/'}
    assert clock_board.board_path(1.0, env) is None
    assert clock_board.board_path(5.0, env).endswith('offboard_py-clock-http_localhost_11312')
    assert clock_board.board_path(5.0, {}) is None
    assert clock_board.board_path(1.0, {clock_board.BOARD_ENV: '/dev/shm/x'}) == '/dev/shm/x'
    assert clock_board.board_path(5.0, dict(env, **{clock_board.BOARD_ENV: ''})) is None


def test_a_governed_sim_clock_sleeps_on_the_held_clock(tmp_path, wall):
    board = board_at(tmp_path, wall)
    clock = SimClock(5.0, monotonic=wall, board=board)
    clock.participant = board.join('sleeper')
    slept = []

    def sleep(wall_s):
        slept.append(wall_s)
        wall.t += wall_s
        board.govern()
    clock._sleep = sleep
    clock.sleep(1.0)
    assert clock.now() >= 501.0 - 1e-9 and max(slept) <= SimClock.POLL_WALL_S + 1e-12
    assert os.path.exists(board.path)


def test_a_stalled_setpoint_stream_holds_the_clock_for_a_while_only():
    from offboard_py.stream_watch import HOLD_WALL_S, STEADY_COUNT, StreamWatch
    watch = StreamWatch()
    sim, wall = 10.0, 100.0
    for _ in range(STEADY_COUNT - 1):
        sim, wall = sim + 0.05, wall + 0.01     # 20 Hz at 5x
        watch.arrived('/my_node', sim, wall)
    assert watch.limit(wall) is None, 'not steady yet'
    sim, wall = sim + 0.05, wall + 0.01
    watch.arrived('/my_node', sim, wall)
    assert watch.limit(wall) == pytest.approx(sim + 0.1), 'two periods past its last setpoint'
    assert watch.limit(wall + HOLD_WALL_S - 0.01) == pytest.approx(sim + 0.1), 'silent: perhaps starved'
    assert watch.limit(wall + HOLD_WALL_S) is None, 'silent for longer: stopped, the clock goes on'
    watch.arrived('/slow', 0.0, wall)
    for k in range(1, 30):
        watch.arrived('/slow', k * 1.0, wall)    # 1 Hz: no stream PX4's offboard mode keeps
    assert watch.limit(wall) == pytest.approx(sim + 0.1)
    watch.forget('/my_node')
    assert watch.limit(wall) is None


def test_a_setpoint_stream_given_up_is_said_once_until_it_streams_again():
    from offboard_py.stream_watch import HOLD_WALL_S, STEADY_COUNT, StreamWatch
    watch = StreamWatch()
    sim, wall = 10.0, 100.0
    for _ in range(STEADY_COUNT):
        sim, wall = sim + 0.05, wall + 0.01
        watch.arrived('/my_node', sim, wall)
    assert watch.let_go(wall + HOLD_WALL_S - 0.01) == [], 'not given up while it may hold the clock'
    assert watch.let_go(wall + HOLD_WALL_S) == [('/my_node', pytest.approx(sim), pytest.approx(HOLD_WALL_S))]
    assert watch.let_go(wall + 2 * HOLD_WALL_S) == [], 'said once'
    assert watch.limit(wall + HOLD_WALL_S + 0.01) is None, 'and held no more'
    watch.arrived('/my_node', sim + 1.0, wall + 1.0)
    assert [g[0] for g in watch.let_go(wall + 1.0 + HOLD_WALL_S)] == ['/my_node'], 'again once back'


def test_a_silent_stream_holds_on_while_its_node_waits_for_the_cpu_but_not_for_ever():
    from offboard_py.stream_watch import HOLD_WALL_S, STARVED_HOLD_WALL_S, STEADY_COUNT, StreamWatch
    starved = {'/starved': True, '/paused': False}
    watch = StreamWatch(runnable=lambda publisher: starved.get(publisher, False))
    sim, wall = 10.0, 100.0
    for _ in range(STEADY_COUNT):
        sim, wall = sim + 0.05, wall + 0.01
        for node in ('/starved', '/paused'):
            watch.arrived(node, sim, wall)
    later = wall + HOLD_WALL_S + 1.0
    assert watch.limit(later) == pytest.approx(sim + 0.1), 'the starved node holds the clock'
    assert [g[0] for g in watch.let_go(later)] == ['/paused'], 'the node that sleeps is let go'
    starved['/starved'] = False
    assert [g[0] for g in watch.let_go(later)] == ['/starved'], 'let go once it no longer waits to run'
    starved['/starved'] = True
    watch.arrived('/starved', sim + 0.05, wall + 0.01)
    assert watch.limit(wall + 0.01 + STARVED_HOLD_WALL_S - 0.1) is not None
    assert watch.limit(wall + 0.01 + STARVED_HOLD_WALL_S) is None, 'never longer than the stale time'


def test_a_process_waits_for_the_cpu_while_a_thread_of_it_is_runnable():
    from offboard_py.ros_participant import waits_for_cpu
    assert waits_for_cpu(os.getpid()), 'this process, running this test'
    sleeper = subprocess.Popen([sys.executable, '-c', 'import time; print("asleep", flush=True); time.sleep(60)'],
                               stdout=subprocess.PIPE)
    try:
        # on a busy machine the interpreter's start takes seconds: wait for it to say it sleeps, then for
        # the scheduler to see it so (it is runnable until it is in the sleep)
        ready, _, _ = select.select([sleeper.stdout], [], [], SLEEPER_START_S)
        assert ready and sleeper.stdout.readline() == b'asleep\n', 'the sleeper did not start in %g s' % SLEEPER_START_S
        deadline = time.monotonic() + SLEEPER_START_S
        while waits_for_cpu(sleeper.pid) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not waits_for_cpu(sleeper.pid), 'a process whose threads all sleep'
    finally:
        sleeper.kill()
        sleeper.wait()
        sleeper.stdout.close()
    assert not waits_for_cpu(sleeper.pid), 'a process that is gone'


def test_a_participant_whose_progress_stands_still_is_left_out_after_the_stale_time(tmp_path, wall):
    """It keeps writing, but the same time (a ROS node whose /clock runs behind on purpose): no hold lasts
    longer than the stale time."""
    board = board_at(tmp_path, wall)
    stuck = board.join('stuck')
    board.govern()
    for _ in range(int(clock_board.STALE_WALL_S / 0.01) + 20):
        wall.t += 0.01
        stuck.update(499.0)
        governed = board.govern()
    assert_left_out_and_running(board, wall, governed)


def test_a_writer_that_died_inside_a_write_does_not_hang_the_readers(tmp_path, wall):
    board = board_at(tmp_path, wall)
    seq = clock_board.struct.unpack('<Q', board._map[8:16])[0]
    board._map[8:16] = clock_board.struct.pack('<Q', seq + 1)   # odd for good
    assert board.now() == pytest.approx(500.0)


def test_the_sweep_removes_only_what_killed_runs_left(tmp_path, wall):
    left = board_at(tmp_path, wall, name='offboard_py-clock-left')  # a run that ended without removing it
    left_path = left.path
    live_path = str(tmp_path / 'offboard_py-clock-live')
    live = clock_board.Board(live_path, 5.0)
    live.join('this process')                             # still in use
    young_path = str(tmp_path / 'offboard_py-clock-young')
    clock_board.Board(young_path, 5.0)                    # made a moment ago: its run may be starting
    other = tmp_path / 'something-else'
    other.write_bytes(b'not ours')
    old = 1e9
    for path in (left_path, live_path, str(other)):
        os.utime(path, (old, old))
    removed = clock_board.sweep(str(tmp_path), now=lambda: old + clock_board.LEFT_OVER_S + 1)
    assert removed == [left_path]
    assert not os.path.exists(left_path)
    assert os.path.exists(live_path) and os.path.exists(young_path) and other.exists()


def test_one_tick_looks_at_a_silent_nodes_process_once():
    """limit() and let_go() of one tick (one wall time) ask whether the node waits for the CPU once: it is a
    read of /proc, 100 times a wall second."""
    from offboard_py.stream_watch import HOLD_WALL_S, STEADY_COUNT, StreamWatch
    asked = []
    watch = StreamWatch(runnable=lambda publisher: asked.append(publisher) or True)
    sim, wall = 10.0, 100.0
    for _ in range(STEADY_COUNT):
        sim, wall = sim + 0.05, wall + 0.01
        watch.arrived('/node', sim, wall)
    tick = wall + HOLD_WALL_S + 1.0
    assert watch.let_go(tick) == [] and watch.limit(tick) is not None
    assert asked == ['/node']
    watch.limit(tick + 0.01)
    assert asked == ['/node', '/node'], 'asked again at the next tick'


def test_a_periodic_sender_late_for_its_send_holds_its_process_slot(tmp_path, wall):
    """A ground station's joystick thread that the CPU left behind: its process's reporting thread still runs,
    but the slot stays at the send due, so the clock waits instead of PX4 counting MANUAL_CONTROL lost."""
    board = board_at(tmp_path, wall)
    client = clock_board.ThreadParticipant(board, 'client')
    try:
        assert client.progress() == pytest.approx(500.0), 'no sender: the clock'
        client.due('joystick', 500.05)
        wall.t += 0.2                                       # 1 simulated second, the joystick not sent
        assert client.progress() == pytest.approx(500.05), 'held at the send due'
        client.due('joystick', None)
        assert client.progress() == pytest.approx(board.now()), 'a sender stopped holds nothing'
    finally:
        client.leave()
