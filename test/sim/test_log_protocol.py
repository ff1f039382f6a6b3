"""The simulated PX4's logs over UDP, as a ground station downloads one (QGroundControl's log download,
MAVSDK's log files): a plain pymavlink client of the simulator's process lists the logs in its log folder,
an earlier run's among them, downloads one whole, asking again for any part it lost as those clients do, and
gets the file's bytes; a bad id gets PX4's answer, which is none. PX4's rules and numbers are its
MavlinkLogHandler's (reference/px4-source-logger.json, "log_handler"). Seconds are simulated ones.
"""

import os

from offboard_py.dialect import mavlink
from offboard_py.sim.autopilot import SimulatedPx4
from offboard_py.testing.reference import load

HANDLER = load('px4-source-logger.json')['log_handler']
ALL, WHOLE = 0xFFFF, 0xFFFFFFFF
EARLIER_RUN_UTC = 1767348000.0  # 2026-01-02 10:00:00: the earlier run's log has a day of its own
QUIET_S = 0.5
ATTEMPTS = 10


class SteppedClock:
    def __init__(self):
        self.now_s = 1000.0

    def __call__(self):
        return self.now_s


def earlier_run(root, armed_s=3.0):
    """A run of the simulator before the test's, on a clock of its own, logging from its arming to its disarm
    (SDLOG_MODE 0), on the day of EARLIER_RUN_UTC; the log's path."""
    clock = SteppedClock()
    ap = SimulatedPx4(local_port=0, remote_port=9, gcs=False, ready_delay_s=0.0, clock=clock, log_dir=str(root),
                      param_overrides=['SDLOG_MODE=0'])
    ap.logger.wall_clock = lambda: EARLIER_RUN_UTC
    codec = mavlink.MAVLink(None, srcSystem=255, srcComponent=mavlink.MAV_COMP_ID_MISSIONPLANNER)

    def run(seconds):
        for _ in range(int(round(seconds / 0.01))):
            clock.now_s += 0.01
            ap.step(0.01)

    def arm(value):
        msg = codec.command_long_encode(ap.system_id, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, value,
                                        0, 0, 0, 0, 0, 0)
        ap.link.handle_datagram(bytes(msg.pack(codec)), ('127.0.0.1', 9))
    try:
        run(0.5)
        arm(1.0)
        run(armed_s)
        arm(0.0)
        run(load('px4-source-logger.json')['logger']['stop_after_disarm_s']['value'] + 0.5)
    finally:
        ap.close()
    (path,) = [os.path.join(d, n) for d, _, names in os.walk(root) for n in names]
    return path


def log_data(client, start, log_id):
    """{ofs: bytes} of the LOG_DATA for log_id received since history index `start`."""
    with client.lock:
        return {m.ofs: bytes(m.data[:m.count]) for _, m in client.history[start:]
                if m.get_type() == 'LOG_DATA' and m.id == log_id}


def wait_quiet(client, start, log_id):
    """Until no LOG_DATA for log_id came for QUIET_S (the handler sends a request's chunks in a few turns)."""
    seen, quiet_since = -1, client.now()
    deadline = client.now() + 20.0
    while client.now() < deadline:
        count = len(log_data(client, start, log_id))
        if count != seen:
            seen, quiet_since = count, client.now()
        elif client.now() - quiet_since >= QUIET_S:
            return
        client.sleep(0.05)


def download(client, target, log_id, size):
    """The log's bytes, asking for the whole of it, then again for each gap, as a ground station does."""
    chunk = HANDLER['log_data_bytes']['value']
    start = len(client.history)
    client.send(client.mav.log_request_data_encode(target, 1, log_id, 0, WHOLE))
    for _ in range(ATTEMPTS):
        wait_quiet(client, start, log_id)
        got = log_data(client, start, log_id)
        missing = [ofs for ofs in range(0, size, chunk) if ofs not in got]
        if not missing:
            break
        for ofs in missing:
            client.send(client.mav.log_request_data_encode(target, 1, log_id, ofs, chunk))
    got = log_data(client, start, log_id)
    assert all(ofs % chunk == 0 and len(data) <= chunk for ofs, data in got.items()), sorted(got)[:5]
    return b''.join(got[ofs] for ofs in sorted(got))


def test_a_ground_station_lists_the_logs_and_downloads_one_whole(start_sim, tmp_path):
    root = tmp_path / 'log'
    earlier = earlier_run(root)
    sim, client = start_sim('--log-dir', str(root), '--ready-delay', '1')
    client.wait_heartbeat()
    files_now = [os.path.join(d, n) for d, _, names in os.walk(root) for n in names]
    assert len(files_now) == 2, 'the earlier run\'s log and the boot log of this one: %s' % files_now

    first_datagram = len(client.datagrams)
    client.send(client.mav.log_request_list_encode(sim.system_id, 1, 0, ALL))

    def listed():
        got = [m for _, m in client.received('LOG_ENTRY')]
        return got if len(got) >= len(files_now) else None
    entries = client.wait_for(listed, 5.0, 'a LOG_ENTRY for each file')
    assert [e.id for e in entries] == list(range(HANDLER['first_log_id']['value'], len(files_now)))
    assert {(e.num_logs, e.last_log_num) for e in entries} == {(len(files_now), len(files_now))}
    info = os.stat(earlier)
    (entry,) = [e for e in entries if (e.size, e.time_utc) == (info.st_size, int(info.st_mtime))]

    with open(earlier, 'rb') as f:
        expected = f.read()
    assert download(client, sim.system_id, entry.id, entry.size) == expected

    bad = len(entries)
    since_bad = len(client.history)
    client.send(client.mav.log_request_data_encode(sim.system_id, 1, bad, 0, WHOLE))
    client.sleep(1.0)
    assert not HANDLER['bad_id_answered']['value'] and log_data(client, since_bad, bad) == {}, 'an id past the list'
    assert all(count == 1 and size <= 296 for _, size, count in client.datagrams[first_datagram:]), \
        'a message a datagram, at most 296 bytes (what mavros reads)'
