"""The benchmark's setpoint log times a setpoint by when its datagram reached the simulator's socket
(the kernel's stamp), not by when a busy simulator got round to reading it, and keeps the read time
beside it (MavlinkLink.stamp_arrivals, sim.instrumentation.SetpointLog). Real UDP on loopback."""

import socket
import time

import pytest

from offboard_py import wire
from offboard_py.dialect import mavlink
from offboard_py.mavlink_link import MavlinkLink
from offboard_py.sim.instrumentation import SetpointLog, StallLog
from offboard_py.simtime import SimClock

LATE_S = 0.3  # how long the datagram waits in the socket before the link reads it


def setpoint():
    return mavlink.MAVLink_set_position_target_local_ned_message(
        1234, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, 0b0000111111111000, 0.0, 0.0, -2.0, 0, 0, 0, 0, 0, 0, 0, 0)


@pytest.fixture
def link_and_sender():
    link = MavlinkLink(('127.0.0.1', 0), None, system_id=1, component_id=1, lock_remote=True)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    yield link, sender
    sender.close()
    link.close()


def send_late(link, sender):
    """Send a setpoint, read it LATE_S later; (Unix ns at sending, arrival_ns seen by the handler, Unix ns at reading)."""
    seen = []
    link.on('SET_POSITION_TARGET_LOCAL_NED', lambda msg: seen.append((link.arrival_ns, time.time_ns())))
    sent_ns = time.time_ns()
    sender.sendto(wire.encode(setpoint(), 0, 255, 190), link.sock.getsockname())
    time.sleep(LATE_S)
    assert link.receive() == 1
    assert len(seen) == 1, 'the setpoint was not handled'
    return sent_ns, seen[0][0], seen[0][1]


def test_the_kernel_stamp_is_the_arrival_not_the_read(link_and_sender):
    link, sender = link_and_sender
    assert link.stamp_arrivals(), 'Linux stamps datagrams (SO_TIMESTAMPNS)'
    sent_ns, arrival_ns, read_ns = send_late(link, sender)
    assert arrival_ns is not None
    assert 0 <= arrival_ns - sent_ns < 50e6, 'arrival %.1f ms after sending' % ((arrival_ns - sent_ns) / 1e6)
    assert read_ns - arrival_ns >= LATE_S * 1e9 * 0.9, 'the stamp is the read time, not the arrival'


def test_without_stamps_there_is_no_arrival(link_and_sender):
    link, sender = link_and_sender
    _sent, arrival_ns, _read = send_late(link, sender)
    assert arrival_ns is None


def test_setpoint_log_keeps_arrival_and_read_in_real_time(tmp_path):
    log = SetpointLog(str(tmp_path / 'setpoints-0.txt'))
    arrival_ns = time.time_ns() - 40000000  # read 40 ms after it arrived
    log.record(setpoint(), arrival_ns)
    log.record(setpoint())  # no kernel stamp: the read time stands for the arrival
    log.write()
    rows = [tuple(map(int, line.split())) for line in open(str(tmp_path / 'setpoints-0.txt'))]
    assert rows[0][0] == arrival_ns and rows[0][1] == 1234
    assert 40e6 <= rows[0][2] - rows[0][0] < 40e6 + 50e6
    assert rows[1][0] == rows[1][2]


def test_setpoint_log_puts_the_arrival_on_the_simulated_clock():
    monotonic = [100.0]
    clock = SimClock(4.0, monotonic=lambda: monotonic[0])
    log = SetpointLog('unused', clock)
    log.record(setpoint(), time.time_ns() - 10000000)  # 10 ms of real time ago: 40 ms of simulated time
    arrival, boot_ms, read = log.rows[0]
    assert read == int(400.0 * 1e9)
    assert 40e6 <= read - arrival < 40e6 + 4 * 50e6


def test_stall_log_says_when_how_far_behind_and_how_many_steps_on_the_setpoint_logs_clock(tmp_path):
    log = StallLog()
    before = time.time_ns()
    log.record(0.8125, 81)
    log.write(str(tmp_path / 'stalls-7.txt'))
    [(when, behind_ms, steps)] = [line.split() for line in open(str(tmp_path / 'stalls-7.txt'))]
    assert before <= int(when) <= time.time_ns() and (behind_ms, steps) == ('812.5', '81')
    StallLog().write(str(tmp_path / 'stalls-8.txt'))
    assert open(str(tmp_path / 'stalls-8.txt')).read() == '', 'written when nothing stalled: none, not unknown'
    simulated = StallLog(SimClock(4.0, monotonic=lambda: 100.0))
    simulated.record(1.2, 120)
    assert simulated.rows[0][0] == int(400.0 * 1e9)
