"""Each answer of the simulated PX4 goes back on the link its request came from, as each of PX4's MAVLink
instances answers on its own: every handler of sim.mavlink.receiver is given the link of its message, and
the parameter and mission managers and the command ACKs are handed that link (no "current link" state).
Offline: the two links of one simulator (onboard and GCS) take real datagrams (handle_datagram), and what
each sends is recorded instead of going out."""

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim.autopilot import SimulatedPx4

from manual_clock import ManualClock

CLIENT = (255, 190)


@pytest.fixture
def autopilot():
    clock = ManualClock(1000.0)
    ap = SimulatedPx4(bind_host='127.0.0.1', local_port=0, remote_port=9, gcs=True, gcs_port=0, gcs_remote_port=9,
                      ready_delay_s=0.0, clock=clock)
    sent = {ap.link: [], ap.gcs_link: []}
    for link in ap.links:
        link.send = lambda msg, link=link: sent[link].append(msg)
        link.send_many = lambda msgs, link=link: sent[link].extend(msgs)
    yield ap, clock, sent
    ap.close_links()


def receive(ap, link, msg):
    """`msg` from the client as a datagram on `link`."""
    codec = mavlink.MAVLink(None, srcSystem=CLIENT[0], srcComponent=CLIENT[1])
    link.handle_datagram(bytes(msg.pack(codec)), ('127.0.0.1', 40000 + ap.links.index(link)))


def kinds(sent, link):
    return [m.get_type() for m in sent[link]]


def other(ap, link):
    return ap.gcs_link if link is ap.link else ap.link


@pytest.mark.parametrize('which', ['onboard', 'GCS'])
def test_parameters_are_answered_on_the_requests_link(autopilot, which):
    ap, clock, sent = autopilot
    link = ap.link if which == 'onboard' else ap.gcs_link
    receive(ap, link, ap.mav.param_request_read_encode(ap.system_id, 1, b'MPC_XY_CRUISE', -1))
    receive(ap, link, ap.mav.param_set_encode(ap.system_id, 1, b'NO_SUCH_PARAM', 1.0,
                                              mavlink.MAV_PARAM_TYPE_REAL32))
    assert kinds(sent, link) == ['PARAM_VALUE', 'PARAM_ERROR']
    assert sent[link][0].param_id == 'MPC_XY_CRUISE'
    assert kinds(sent, other(ap, link)) == []
    receive(ap, link, ap.mav.param_request_list_encode(ap.system_id, 1))
    assert list(ap.parameters.param_lists) == [link], 'the list goes out on the requesting link'


@pytest.mark.parametrize('which', ['onboard', 'GCS'])
def test_a_command_its_answer_and_its_ack_go_back_on_its_link(autopilot, which):
    ap, clock, sent = autopilot
    link = ap.link if which == 'onboard' else ap.gcs_link
    receive(ap, link, ap.mav.command_long_encode(ap.system_id, 1, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION, 0,
                                                 1, 0, 0, 0, 0, 0, 0))
    clock.now_s += 0.01
    ap.command_sender.send_deferred()
    assert kinds(sent, link) == ['PROTOCOL_VERSION', 'COMMAND_ACK']
    assert kinds(sent, other(ap, link)) == []


def test_message_intervals_are_each_links_own(autopilot):
    """GET_MESSAGE_INTERVAL reads the streams of the link it came on: ATTITUDE at 100 Hz onboard, 50 Hz on
    the GCS link (sim.mavlink.streams)."""
    ap, clock, sent = autopilot
    for link in ap.links:
        receive(ap, link, ap.mav.command_long_encode(ap.system_id, 1, mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, 0,
                                                     mavlink.MAVLINK_MSG_ID_ATTITUDE, 0, 0, 0, 0, 0, 0))
    intervals = {link: [m.interval_us for m in sent[link] if m.get_type() == 'MESSAGE_INTERVAL'] for link in ap.links}
    assert intervals == {ap.link: [10000], ap.gcs_link: [20000]}


def test_a_mission_download_ping_and_timesync_are_answered_on_their_link(autopilot):
    ap, clock, sent = autopilot
    receive(ap, ap.gcs_link, ap.mav.mission_request_list_encode(ap.system_id, 1, mavlink.MAV_MISSION_TYPE_MISSION))
    receive(ap, ap.link, ap.mav.ping_encode(123, 7, 0, 0))
    receive(ap, ap.link, ap.mav.timesync_encode(0, 42))
    assert kinds(sent, ap.gcs_link) == ['MISSION_COUNT']
    assert kinds(sent, ap.link) == ['PING', 'TIMESYNC']
    assert ap.mission_manager.partner_link is ap.gcs_link


def test_the_setpoint_probe_is_given_the_setpoints_link(autopilot):
    ap, clock, sent = autopilot
    got = []
    ap.setpoint_probes.append(lambda msg, link: got.append((msg.get_type(), link)))
    receive(ap, ap.gcs_link, ap.mav.set_position_target_local_ned_encode(
        0, ap.system_id, 1, mavlink.MAV_FRAME_LOCAL_NED, 0b0000111111111000, 0.0, 0.0, -2.0,
        0, 0, 0, 0, 0, 0, 0, 0))
    assert got == [('SET_POSITION_TARGET_LOCAL_NED', ap.gcs_link)]


def test_the_autopilot_keeps_no_current_link(autopilot):
    ap, _, _ = autopilot
    assert [name for name in vars(ap) if 'reply' in name] == [] and not hasattr(ap, 'reply')
