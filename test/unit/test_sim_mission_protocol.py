"""The simulated PX4's side of the mission protocol, offline: PX4 main's MavlinkMissionManager state machine
(mavlink_mission.cpp at the recorded 02e73e3b6f) driven message by message, the messages it sends collected
as a link would send them."""

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim.mavlink import mission_manager

M = mavlink
MISSION, FENCE = M.MAV_MISSION_TYPE_MISSION, M.MAV_MISSION_TYPE_FENCE
GCS = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
OTHER = mavlink.MAVLink(None, srcSystem=254, srcComponent=1)
BUILD = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)


class Link:
    """Where the transfer's messages go: kept in order."""

    def __init__(self):
        self.sent = []

    def send(self, msg):
        self.sent.append(msg)


class Rig:
    def __init__(self):
        self.link = Link()
        self.texts, self.changes = [], []
        self.transfer = mission_manager.MissionManager(BUILD, 1, self.texts.append, self.changes.append)

    def sent(self, kind=None):
        return [m for m in self.link.sent if kind is None or m.get_type() == kind]

    def acks(self):
        return [m.type for m in self.sent('MISSION_ACK')]

    def receive(self, msg, now_s, sender=GCS):
        """`msg` as decoded from a frame of `sender`."""
        decoded = BUILD.decode(bytearray(msg.pack(sender)))
        handler = {'MISSION_COUNT': self.transfer.on_count, 'MISSION_ITEM_INT': self.transfer.on_item,
                   'MISSION_ITEM': self.transfer.on_item, 'MISSION_REQUEST_LIST': self.transfer.on_request_list,
                   'MISSION_REQUEST_INT': self.transfer.on_request, 'MISSION_REQUEST': self.transfer.on_request,
                   'MISSION_ACK': self.transfer.on_ack, 'MISSION_CLEAR_ALL': self.transfer.on_clear_all}
        assert self.transfer.for_me(decoded), 'addressed to system 1'
        handler[decoded.get_type()](decoded, now_s, self.link)


def count(n, mtype=MISSION):
    return GCS.mission_count_encode(1, 1, n, mtype)


def waypoint(seq, frame=M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command=M.MAV_CMD_NAV_WAYPOINT, mtype=MISSION):
    return GCS.mission_item_int_encode(1, 1, seq, frame, command, 0, 1, 0, 1, 0, 0, 473977420, 85455940, 5.0, mtype)


@pytest.fixture
def rig():
    return Rig()


def test_an_upload_asks_again_every_250_ms_and_is_dropped_5_s_after_the_client_last_spoke(rig):
    rig.receive(count(2), 0.0)
    for t in [i * 0.01 for i in range(1, 601)]:  # 6 s of the simulator's 10 ms cycles
        rig.transfer.tick(t)
    requests = rig.sent('MISSION_REQUEST_INT')
    assert all(r.seq == 0 for r in requests)
    assert len(requests) == 20, 'at 0 s, then every 0.26 s (the first cycle past 250 ms) until 5 s: %d' % len(requests)
    assert rig.acks() == [] and rig.texts == ['Operation timeout'], 'PX4 sends no MISSION_ACK, only the text'
    assert rig.transfer.state == rig.transfer.IDLE
    rig.receive(waypoint(0), 6.1)
    assert rig.acks() == [M.MAV_MISSION_ERROR], 'an item after the timeout: no transfer'


def test_a_completed_upload_and_the_last_item_again(rig):
    rig.receive(count(2), 0.0)
    rig.receive(waypoint(0), 0.1)
    rig.receive(waypoint(1), 0.2)
    assert [r.seq for r in rig.sent('MISSION_REQUEST_INT')] == [0, 1]
    assert rig.acks() == [M.MAV_MISSION_ACCEPTED] and rig.changes == [MISSION]
    rig.receive(waypoint(1), 0.3)
    assert rig.acks() == [M.MAV_MISSION_ACCEPTED] * 2, 'our ACK was lost: the last item is acknowledged again'


@pytest.mark.parametrize('item, result', [
    (waypoint(0, frame=M.MAV_FRAME_LOCAL_NED), M.MAV_MISSION_UNSUPPORTED_FRAME),
    (waypoint(0, frame=M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT), M.MAV_MISSION_UNSUPPORTED_FRAME),
    (waypoint(0, command=31999), M.MAV_MISSION_UNSUPPORTED),
    (waypoint(0, frame=M.MAV_FRAME_MISSION), M.MAV_MISSION_UNSUPPORTED),  # a waypoint needs coordinates
    (waypoint(0, command=M.MAV_CMD_NAV_RALLY_POINT), M.MAV_MISSION_ERROR),  # not in a mission
    # SDKs append NAV_RETURN_TO_LAUNCH; in a global frame PX4 answered MISSION_ACK 3 and kept no mission
    # (reference/px4-sitl-measured.md, "Turn 4 recordings" item 1): only MAV_FRAME_MISSION carries it
    (waypoint(0, command=M.MAV_CMD_NAV_RETURN_TO_LAUNCH), M.MAV_MISSION_UNSUPPORTED),
])
def test_items_px4_cannot_parse_end_the_upload(rig, item, result):
    rig.receive(count(2), 0.0)
    rig.receive(item, 0.1)
    assert rig.acks() == [result] and rig.texts == ['IGN MISSION_ITEM: Invalid item']
    assert rig.transfer.state == rig.transfer.IDLE and rig.changes == []


def test_a_legacy_item_with_an_int_frame_is_refused_as_px4(rig):
    rig.receive(count(1), 0.0)
    legacy = GCS.mission_item_encode(1, 1, 0, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                     0, 1, 0, 0, 47.39, 8.54, 5.0, MISSION)
    rig.receive(legacy, 0.1)
    assert rig.acks() == [M.MAV_MISSION_UNSUPPORTED_FRAME]


@pytest.mark.parametrize('n, mtype, result', [(10000, MISSION, None), (10001, MISSION, M.MAV_MISSION_NO_SPACE),
                                              (64, FENCE, None), (65, FENCE, M.MAV_MISSION_NO_SPACE),
                                              (1, 7, M.MAV_MISSION_NO_SPACE)])
def test_item_limits_are_px4_sitls(rig, n, mtype, result):
    rig.receive(count(n, mtype), 0.0)
    if result is None:
        assert rig.acks() == [] and rig.sent('MISSION_REQUEST_INT')[0].seq == 0
    else:
        assert rig.acks() == [result]


def test_busy_answers_during_an_upload(rig):
    rig.receive(count(3), 0.0)
    rig.receive(count(3), 0.05)
    assert [r.seq for r in rig.sent('MISSION_REQUEST_INT')] == [0, 0], 'no item yet: ask again'
    rig.receive(waypoint(0), 0.1)
    rig.receive(count(3), 0.15)
    assert rig.acks() == [M.MAV_MISSION_ERROR] and rig.texts == ['WPM: REJ. CMD: Busy']
    rig.receive(count(1), 0.2, sender=OTHER)
    assert [(a.target_system, a.type) for a in rig.sent('MISSION_ACK')][-1] == (254, M.MAV_MISSION_ERROR)
    rig.receive(waypoint(1), 0.3)
    rig.receive(waypoint(2), 0.4)
    assert rig.acks()[-1] == M.MAV_MISSION_ACCEPTED and len(rig.transfer.mission()) == 3, 'the upload went on'


def test_download_requests_out_of_turn(rig):
    rig.receive(count(2), 0.0)
    rig.receive(waypoint(0), 0.1)
    rig.receive(waypoint(1), 0.2)
    before = len(rig.link.sent)
    rig.receive(GCS.mission_request_int_encode(1, 1, 0, MISSION), 0.3)
    assert len(rig.link.sent) == before, 'no download under way: PX4 ignores it silently'
    rig.receive(GCS.mission_request_list_encode(1, 1, MISSION), 0.4)
    assert rig.sent('MISSION_COUNT')[-1].count == 2
    rig.receive(GCS.mission_request_int_encode(1, 1, 0, MISSION), 0.5)
    rig.receive(GCS.mission_request_int_encode(1, 1, 0, MISSION), 0.6)  # the same again: answered again
    assert [m.seq for m in rig.sent('MISSION_ITEM_INT')] == [0, 0]
    rig.receive(GCS.mission_request_int_encode(1, 1, 5, MISSION), 0.7)
    assert rig.acks()[-1] == M.MAV_MISSION_ERROR and rig.texts[-1] == 'WPM: REJ. CMD: Req. WP was unexpected'
    assert rig.transfer.state == rig.transfer.IDLE


def test_downloaded_items_come_back_as_px4_keeps_them(rig):
    """mavlink_mission.cpp format_mavlink_mission_item: a positional item comes back in GLOBAL_RELATIVE_ALT_INT to
    MISSION_REQUEST_INT (reference/px4-sitl-measured.md, "Turn 5": frame 6), GLOBAL_RELATIVE_ALT to the legacy
    request, with the fields PX4 kept (a waypoint's pass radius, param3, dropped; its yaw wrapped to 0..360);
    a MAV_FRAME_MISSION item as it came."""
    rig.receive(count(2), 0.0)
    rig.receive(GCS.mission_item_int_encode(1, 1, 0, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                            2.0, 1.5, 4.0, -90.0, 473977420, 85455940, 5.0, MISSION), 0.1)
    rig.receive(GCS.mission_item_int_encode(1, 1, 1, M.MAV_FRAME_MISSION, M.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 1,
                                            0.0, 0.0, 0.0, 0.0, 0, 0, 0.0, MISSION), 0.2)
    assert rig.acks() == [M.MAV_MISSION_ACCEPTED]
    rig.receive(GCS.mission_request_list_encode(1, 1, MISSION), 0.3)
    rig.receive(GCS.mission_request_int_encode(1, 1, 0, MISSION), 0.4)
    rig.receive(GCS.mission_request_int_encode(1, 1, 1, MISSION), 0.5)
    wp, rtl = rig.sent('MISSION_ITEM_INT')
    assert wp.frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT and (wp.x, wp.y, wp.z) == (473977420, 85455940, 5.0)
    assert (wp.param1, wp.param2, wp.param3) == (2.0, 1.5, 0.0) and wp.param4 == pytest.approx(270.0, abs=1e-3)
    assert (rtl.frame, rtl.command) == (M.MAV_FRAME_MISSION, M.MAV_CMD_NAV_RETURN_TO_LAUNCH)
    rig.receive(GCS.mission_ack_encode(1, 1, M.MAV_MISSION_ACCEPTED, MISSION), 0.6)
    rig.receive(GCS.mission_request_list_encode(1, 1, MISSION), 0.7)
    rig.receive(GCS.mission_request_encode(1, 1, 0, MISSION), 0.8)
    assert rig.sent('MISSION_ITEM')[-1].frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT


def test_only_its_own_system_id(rig):
    for target, component, taken in ((1, 1, True), (1, 0, True), (1, 190, True), (0, 1, False), (1, 42, False),
                                     (2, 1, False)):
        msg = BUILD.decode(bytearray(GCS.mission_request_list_encode(target, component, MISSION).pack(GCS)))
        assert rig.transfer.for_me(msg) is taken, (target, component)
