"""When the simulated PX4 answers, on its own clock, with no network timing in the way: PX4 SITL
sends what a request asks for at once and the COMMAND_ACK about 4 ms later (reference/px4-sitl-
measured.md, "Turn 3 recordings", section 4: PROTOCOL_VERSION's ACK ~4 ms after it, DO_SET_MODE's
two ACKs 1-8 ms apart). Over UDP (test/sim/test_px4_answers.py) the bound is generous for a loaded
machine; here the simulator's own delays are held exactly."""

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim.autopilot import SimulatedPx4

from manual_clock import ManualClock

RECORDED_ACK_AFTER_S = (0.001, 0.008)


@pytest.fixture
def autopilot():
    clock = ManualClock(1000.0)
    ap = SimulatedPx4(bind_host='127.0.0.1', local_port=0, remote_port=9, gcs=False, ready_delay_s=0.0, clock=clock)
    sent = []
    codec = mavlink.MAVLink(None, srcSystem=ap.system_id, srcComponent=1)

    def send(msg):  # the frame the link would put in a datagram, decoded back
        decoded = codec.decode(bytearray(msg.pack(codec)))
        sent.append((clock.now_s, decoded.get_type(), decoded))
    ap.link.send = send
    yield ap, clock, sent
    ap.close_links()


def command_long(ap, command, *params):
    params = (list(params) + [0.0] * 7)[:7]
    msg = ap.link.mav.command_long_encode(ap.system_id, 1, command, 0, *params)
    msg._header = mavlink.MAVLink_header(msg.get_msgId(), srcSystem=255, srcComponent=190)
    ap.receiver._on_command(msg, ap.link)


def run_until(ap, clock, seconds, dt=0.0005):
    for _ in range(int(seconds / dt)):
        clock.now_s += dt
        ap.command_sender.send_deferred()


def test_protocol_version_at_once_and_its_ack_about_4_ms_later(autopilot):
    ap, clock, sent = autopilot
    t0 = clock.now_s
    command_long(ap, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION, 1)
    run_until(ap, clock, 0.02)
    got = [(t - t0, kind) for t, kind, _ in sent if kind in ('PROTOCOL_VERSION', 'COMMAND_ACK')]
    assert [kind for _, kind in got] == ['PROTOCOL_VERSION', 'COMMAND_ACK']
    assert got[0][0] == 0.0, 'PROTOCOL_VERSION is sent while the request is handled'
    assert RECORDED_ACK_AFTER_S[0] <= got[1][0] - got[0][0] <= RECORDED_ACK_AFTER_S[1]


def test_do_set_mode_in_a_command_long_gets_two_acks_1_to_8_ms_apart(autopilot):
    ap, clock, sent = autopilot
    command_long(ap, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3)
    run_until(ap, clock, 0.05)
    acks = [(t, msg) for t, kind, msg in sent if kind == 'COMMAND_ACK' and msg.command == mavlink.MAV_CMD_DO_SET_MODE]
    assert len(acks) == 2
    assert RECORDED_ACK_AFTER_S[0] <= acks[1][0] - acks[0][0] <= RECORDED_ACK_AFTER_S[1]
    assert [m.target_system for _, m in acks] == [255, 255]
