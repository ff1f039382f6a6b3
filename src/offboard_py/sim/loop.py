"""The simulated PX4's loop: `run_together(sims)` runs one vehicle (SimulatedPx4.run) or a fleet in one
process (`sim_px4.py --vehicles N`) on their clock, waking once for all of them."""

import logging
import select

log = logging.getLogger('offboard_py.sim')  # the simulated PX4's one log
STALL_S = 0.25  # wall seconds behind its clock: the loop skips the steps missed and goes on from now


def run_together(sims, duration_s=None, on_stall=None):
    """Run simulated PX4s in one loop on their (shared) clock until each is stopped, or for duration_s
    of its seconds: a fleet in one process wakes once for all its vehicles, where a process each wakes
    once each (`sim_px4.py --vehicles N`).

    The flight stacks step every 1/rate_hz s on the loop's schedule, and the process wakes every
    steps_per_wakeup steps (and when a datagram comes in: requests are answered and setpoints taken at
    once): the due steps run, and their streams go out, each message in a datagram of its own as PX4
    sends them (real mavros reads at most 296 bytes of a datagram). A wake-up costs more than a sendto
    (on the development machine the first sendto after 20 ms asleep takes 55-65 us, the next 8 us), so
    two steps share one: every message keeps its own step's time and values, and the first step's
    messages of a pair leave one step (10 ms) after their time_boot_ms.

    Fallen more than STALL_S (wall) behind the clock, the loop skips the steps it missed, and their
    streams, and goes on from now: it says so, and calls on_stall(seconds behind, steps skipped)."""
    first = sims[0]
    clock, period, batch = first.clock, 1.0 / first.rate_hz, first.steps_per_wakeup
    if any(sim.clock is not clock or sim.rate_hz != first.rate_hz or sim.steps_per_wakeup != batch for sim in sims):
        raise ValueError('simulated PX4s run together share one clock, rate and steps per wake-up')
    speed = getattr(clock, 'speed', 1.0)
    governed = getattr(clock, 'board', None) is not None
    # epoll: a fleet's process asks for its 2 sockets a vehicle at every wake-up and after every vehicle's
    # burst, and poll() looks at all of them each time (64 for 32 vehicles) where epoll hands over the ready
    poller = select.epoll()
    by_fd = {}
    for sim in sims:
        sim.running = True
        for link in sim.links:
            by_fd[link.fileno()] = link
            poller.register(link.fileno(), select.EPOLLIN)
        for link, kind in zip(sim.links, ('onboard', 'GCS')):
            log.info('simulated PX4 sysid %d, %s link on udp %s:%d -> %s:%d', sim.system_id, kind, link.bind[0],
                     link.bind[1], *link.remote)
    if speed != 1.0:
        log.info('simulated time at %gx real time', speed)
    next_s = clock()  # the schedule's time of the next step
    stalls = steps_skipped = 0
    at_speed = ' at %gx' % speed if speed != 1.0 else ''
    if speed != 1.0:
        why = ' at that speed'
    elif len(sims) > 1:
        why = (' with %d vehicles in one process (a process runs on one core; multi_uav.launch vehicles_per_sim '
               'sets how many share one)' % len(sims))
    else:
        why = ''
    end_s = None if duration_s is None else next_s + duration_s
    try:
        while any(sim.running for sim in sims) and (end_s is None or clock() < end_s):
            wake_s = next_s + (batch - 1) * period
            until_s = min([wake_s] + [d[0] for sim in sims for d in sim.command_sender.deferred])
            wait_s = max(0.0, until_s - clock()) / speed
            if governed:  # the clock may be held: look again soon, and say how far this loop has got
                clock.progress()
                wait_s = min(wait_s, clock.POLL_WALL_S)
            for fd, _ in poller.poll(wait_s):
                by_fd[fd].receive()
            now = clock()
            for sim in sims:
                sim.command_sender.send_deferred(now)
            if now < wake_s:
                continue
            if now - next_s > STALL_S * speed:  # stalled (suspended, overloaded): resynchronise
                skipped = int((now - next_s) / period)
                stalls, steps_skipped = stalls + 1, steps_skipped + skipped
                if on_stall is not None:
                    on_stall(now - next_s, skipped)
                if stalls in (1, 10, 100, 1000) or stalls % 10000 == 0:
                    log.warning('the simulator fell %.2f s behind its clock%s and skipped %d steps of its %d '
                                'vehicle(s), their streams with them (%d times so far, %d steps): this machine '
                                'cannot keep up%s', now - next_s, at_speed, skipped, len(sims), stalls,
                                steps_skipped, why)
                for sim in sims:
                    if sim.running:
                        sim.step(period)
                next_s = now + period
                continue
            # Streams are timed by each step's slot on the schedule, not by when poll() woke: at
            # speed K a wake-up jitter of j wall seconds is K x j simulated ones, and at 10x a 1 ms
            # late wake-up is a whole 100 Hz period: ATTITUDE, due every step, skipped one in three.
            due = []
            while next_s <= now:
                due.append(next_s)
                next_s += period
            for sim in sims:
                if not sim.running:
                    continue
                out = {}
                for slot_s in due:
                    sim.step(period, slot_s - sim.boot_s, out)
                for link, msgs in out.items():
                    link.send_many(msgs)  # a datagram per message, as PX4 (MavlinkLink.send_many)
                if len(sims) > 1:  # what came in meanwhile is read now, not after every vehicle's turn
                    for fd, _ in poller.poll(0):
                        by_fd[fd].receive()
    finally:
        poller.close()
        if stalls:
            log.warning('the simulator skipped %d steps of each vehicle, their streams with them, in %d stalls '
                        '(each more than %g s of wall time behind its clock)', steps_skipped, stalls, STALL_S)
