"""The simulated PX4's log protocol (sim.mavlink.log_handler), offline: LOG_REQUEST_LIST, LOG_REQUEST_DATA,
LOG_REQUEST_END and LOG_ERASE handed to its links as datagrams, on a clock that moves only when the test moves
it, the answers read from UDP sockets of the test's own on loopback.

What PX4 answers, numbers included, is its MavlinkLogHandler's (reference/px4-source-logger.json,
"log_handler": src/modules/mavlink/mavlink_log_handler.cpp at the recorded commit). SDLOG_MODE 0 keeps the
simulator from logging its own boot, so the folder holds the files each test puts there.
"""

import math
import os
import socket

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim.autopilot import SimulatedPx4
from offboard_py.testing.reference import load

from manual_clock import ManualClock

STEP_S = 0.01
SO_RCVBUFFORCE = 33  # Linux's, which Python does not name
RECEIVE_BUFFER_BYTES = 16 << 20
ALL = 0xFFFF
WHOLE = 0xFFFFFFFF
HANDLER = load('px4-source-logger.json')['log_handler']


def figure(name):
    return HANDLER[name]['value']


class Rig:
    """The simulator with `log_root` (None: none) and both links, each sending to a socket of the test's."""

    def __init__(self, log_root):
        self.clock = ManualClock(1000.0)
        self.socks = {}
        for name in ('onboard', 'gcs'):
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.bind(('127.0.0.1', 0))
            sock.setblocking(False)
            try:  # a whole burst between two reads: past net.core.rmem_max, for root
                sock.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, RECEIVE_BUFFER_BYTES)
            except PermissionError:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER_BYTES)
            self.socks[name] = sock
        self.ap = SimulatedPx4(local_port=0, remote_port=self.socks['onboard'].getsockname()[1], gcs_port=0,
                               gcs_remote_port=self.socks['gcs'].getsockname()[1], ready_delay_s=0.0,
                               clock=self.clock, param_overrides=['SDLOG_MODE=0'],
                               log_dir=None if log_root is None else str(log_root))
        self.links = {'onboard': self.ap.link, 'gcs': self.ap.gcs_link}
        self.codec = mavlink.MAVLink(None, srcSystem=255, srcComponent=mavlink.MAV_COMP_ID_MISSIONPLANNER)
        self.readers = {name: mavlink.MAVLink(None) for name in self.socks}
        self.got = {name: [] for name in self.socks}  # (step, message)
        self.steps = 0

    def send(self, msg, link='onboard'):
        self.links[link].handle_datagram(bytes(msg.pack(self.codec)), self.socks[link].getsockname())

    def request_list(self, start=0, end=ALL, link='onboard'):
        self.send(self.codec.log_request_list_encode(self.ap.system_id, 1, start, end), link)

    def request_data(self, log_id, ofs=0, count=WHOLE, link='onboard'):
        self.send(self.codec.log_request_data_encode(self.ap.system_id, 1, log_id, ofs, count), link)

    def run(self, seconds):
        for _ in range(int(round(seconds / STEP_S))):
            self.clock.now_s += STEP_S
            self.ap.step(STEP_S)
            self.steps += 1
            self.read()

    def read(self):
        for name, sock in self.socks.items():
            while True:
                try:
                    data = sock.recv(65536)
                except BlockingIOError:
                    break
                msgs = self.readers[name].parse_buffer(data) or []
                assert len(msgs) == 1 and len(data) <= 296, 'one message a datagram, as PX4 frames them'
                self.got[name] += [(self.steps, m) for m in msgs]

    def of(self, kind, link='onboard', since=0):
        return [m for _, m in self.got[link][since:] if m.get_type() == kind]

    def mark(self, link='onboard'):
        return len(self.got[link])

    def close(self):
        self.ap.close()
        for sock in self.socks.values():
            sock.close()


@pytest.fixture
def folder(tmp_path):
    """A log folder with two days of logs of earlier runs, a stray file and an empty day."""
    root = tmp_path / 'log'
    (root / '2026-01-02').mkdir(parents=True)
    (root / '2026-01-02' / '10_00_00.ulg').write_bytes(bytes(range(256)) * 4 + b'end')
    (root / '2026-01-03').mkdir()
    (root / '2026-01-03' / '11_30_00.ulg').write_bytes(os.urandom(95))
    (root / '2026-01-03' / '12_00_00.ulg').write_bytes(b'')
    (root / '2026-01-04').mkdir()
    (root / 'stray.txt').write_text('not in a day\'s folder: not listed')
    return root


def listed(root):
    """The files of root's folders, in the order the file system gives them (what PX4's readdir walks)."""
    return [entry.path for day in os.scandir(root) if day.is_dir() for entry in os.scandir(day.path)
            if entry.is_file()]


@pytest.fixture
def rig(folder):
    r = Rig(folder)
    yield r
    r.close()


def test_the_list_has_every_file_of_every_day_numbered_from_0_with_its_size_and_time(rig, folder):
    files = listed(folder)
    rig.request_list()
    rig.run(0.05)
    entries = rig.of('LOG_ENTRY')
    assert [e.id for e in entries] == list(range(figure('first_log_id'), len(files)))
    assert {e.num_logs for e in entries} == {len(files)}
    assert figure('last_log_num_is_num_logs') and {e.last_log_num for e in entries} == {len(files)}
    for entry, path in zip(entries, files):
        info = os.stat(path)
        assert (entry.size, entry.time_utc) == (info.st_size, int(info.st_mtime)), path
    assert rig.of('LOG_ENTRY', 'gcs') == [], 'answers go on the link the request came from'

    start = rig.mark()
    rig.request_list(start=2)
    rig.run(0.05)
    assert [e.id for e in rig.of('LOG_ENTRY', since=start)] == list(range(2, len(files)))


def test_a_log_comes_whole_in_90_byte_chunks_on_the_link_that_asked(rig, folder):
    files = listed(folder)
    rig.request_list(link='gcs')
    rig.run(0.05)
    log_id = max(range(len(files)), key=lambda i: os.path.getsize(files[i]))
    rig.request_data(log_id, link='gcs')
    rig.run(0.05)
    chunks = rig.of('LOG_DATA', 'gcs')
    expected = open(files[log_id], 'rb').read()
    assert [c.ofs for c in chunks] == list(range(0, len(expected), figure('log_data_bytes')))
    assert all(c.id == log_id for c in chunks)
    assert b''.join(bytes(c.data[:c.count]) for c in chunks) == expected
    assert [c.count for c in chunks[:-1]] == [figure('log_data_bytes')] * (len(chunks) - 1)
    assert rig.of('LOG_DATA') == []


def test_a_request_is_answered_in_whole_chunks_until_its_count_is_reached(rig, folder):
    files = listed(folder)
    rig.request_list()
    rig.run(0.05)
    log_id = max(range(len(files)), key=lambda i: os.path.getsize(files[i]))
    chunk = figure('log_data_bytes')
    rig.request_data(log_id, ofs=chunk, count=chunk + 10)
    rig.run(0.05)
    assert [(c.ofs, c.count) for c in rig.of('LOG_DATA')] == [(chunk, chunk), (2 * chunk, chunk)]


def test_what_px4_leaves_unanswered(rig, folder):
    files = listed(folder)
    rig.request_data(0)
    rig.run(0.1)
    assert rig.of('LOG_DATA') == [], 'data before a list'
    rig.request_list()
    rig.run(0.05)
    rig.request_data(len(files))
    rig.run(0.1)
    assert rig.of('LOG_DATA') == [] and not figure('bad_id_answered'), 'an id past the list'
    log_id = next(i for i, path in enumerate(files) if os.path.getsize(path) > 0)
    rig.request_data(log_id, ofs=os.path.getsize(files[log_id]))
    rig.run(0.1)
    assert rig.of('LOG_DATA') == [] and not figure('offset_past_end_answered'), 'an offset at the end'


def test_no_log_folder_and_an_empty_one_list_nothing(tmp_path):
    for root in (None, tmp_path / 'empty'):
        if root is not None:
            root.mkdir()
        r = Rig(root)
        try:
            r.request_list()
            r.run(0.1)
            assert r.of('LOG_ENTRY') == [] and not figure('no_log_dir_answered'), root
        finally:
            r.close()


def test_a_big_log_goes_out_at_px4s_burst_a_turn_and_stops_at_log_request_end(tmp_path):
    root = tmp_path / 'log'
    (root / '2026-01-02').mkdir(parents=True)
    per_turn = math.ceil(figure('max_bytes_burst') / figure('log_data_frame_bytes'))
    size = figure('log_data_bytes') * per_turn * 3
    (root / '2026-01-02' / '10_00_00.ulg').write_bytes(os.urandom(size))
    r = Rig(root)
    try:
        r.request_list()
        r.run(0.05)
        start = r.mark()
        r.request_data(0)
        turns = 2
        r.run(turns * figure('send_period_s'))
        assert len(r.of('LOG_DATA', since=start)) == turns * per_turn
        r.send(r.codec.log_request_end_encode(r.ap.system_id, 1))
        stopped = r.mark()
        r.run(0.1)
        assert r.of('LOG_DATA', since=stopped) == []
    finally:
        r.close()


def test_log_erase_removes_every_log_and_folder(rig, folder):
    rig.send(rig.codec.log_erase_encode(rig.ap.system_id, 1))
    rig.run(0.05)
    assert os.listdir(folder) == [], figure('erase_removes')
    rig.request_list()
    rig.run(0.05)
    assert rig.of('LOG_ENTRY') == []
