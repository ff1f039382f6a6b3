"""The transport half of the link (offboard_py.mavlink_transport) on its own, and its boundary with the router
(MavlinkLink): framing and checks, sequence loss, the counters, and the transport's names on the link.
No socket traffic: datagrams are fed in."""

import pytest

from offboard_py import mavlink_link, mavlink_transport, wire
from offboard_py.dialect import mavlink
from offboard_py.mavlink_link import MavlinkLink
from offboard_py.mavlink_transport import UdpTransport

HB = mavlink.MAVLink_heartbeat_message(2, 12, 29, 0x03040000, 3, 3)
ATT = mavlink.MAVLink_attitude_message(1000, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0)


@pytest.fixture
def transport():
    endpoint = UdpTransport(('127.0.0.1', 0), None, system_id=255, component_id=1)
    yield endpoint
    endpoint.close()


def test_frames_are_the_checked_frames_with_source_and_sequence(transport):
    v1 = mavlink.MAVLink(None, srcSystem=7, srcComponent=8)
    v1.seq = 42
    bad = bytearray(wire.encode(ATT, 3, 1, 1))
    bad[-1] ^= 0xFF
    data = (wire.encode(HB, 9, 1, 190) + b'junk' + bytes(bad) + HB.pack(v1, force_mavlink1=True)
            + wire.encode(ATT, 4, 2, 1))
    walked = iter(transport.frames(data))
    assert next(walked)[1:] == (wire.encode(HB, 9, 1, 190), (1, 190), 9)
    assert transport.stats['bad_frames'] == 0, 'counted once the datagram is walked to its end'
    rest = list(walked)
    assert [(msg_id, source, seq) for msg_id, _, source, seq in rest] == [
        (mavlink.MAVLINK_MSG_ID_HEARTBEAT, (7, 8), 42), (mavlink.MAVLINK_MSG_ID_ATTITUDE, (2, 1), 4)]
    assert transport.stats['bad_frames'] == 2, 'the junk and the bad CRC'


def test_lone_frame_is_one_unsigned_mavlink2_frame_and_nothing_else(transport):
    one = wire.encode(ATT, 0, 1, 1)
    assert transport.lone_frame(one) == mavlink.MAVLINK_MSG_ID_ATTITUDE
    signed = bytearray(one)
    signed[2] = wire.IFLAG_SIGNED
    assert transport.lone_frame(bytes(signed)) is None
    assert transport.lone_frame(one + one) is None and transport.lone_frame(one[:-1]) is None
    v1 = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    assert transport.lone_frame(HB.pack(v1, force_mavlink1=True)) is None


def test_sequence_loss_is_counted_per_sender_and_wraps(transport):
    for source, seq in (((1, 1), 250), ((1, 1), 252), ((2, 1), 10), ((1, 1), 1), ((2, 1), 11)):
        transport.count_sequence(source, seq)
    assert transport.stats['dropped'] == 1 + 4 and transport.last_seq((1, 1)) == 1
    assert transport.last_seq((3, 1)) == 0
    transport.count_sequence((1, 1), 2)
    assert 'dropped' in transport.stats and transport.stats['dropped'] == 5, 'no gap, nothing counted'


def test_a_signature_is_checked_only_when_signing_is_on(transport):
    frame = wire.encode(HB, 0, 1, 1)
    assert transport.check_signature(0, frame) == (True, False)
    transport.enable_signing(bytes(range(1, 33)))
    assert transport.check_signature(0, frame) == (False, False)
    assert transport.stats['unsigned_rejected'] == 1


def test_the_link_is_a_router_over_its_transport():
    link = MavlinkLink(('127.0.0.1', 0), ('127.0.0.1', 14580), system_id=3, component_id=1, name='udp7')
    try:
        transport = link.transport
        assert (link.sock, link.mav, link.stats, link.signing) == (transport.sock, transport.mav, transport.stats,
                                                                    transport.signing)
        assert (link.bind, link.name, link.remote, link.system_id) == (transport.bind, 'udp7', ('127.0.0.1', 14580), 3)
        link.handle_datagram(wire.encode(HB, 5, 1, 1), ('127.0.0.1', 14590))
        assert link.remote == transport.remote == ('127.0.0.1', 14590) and link.last_seq((1, 1)) == 5
        assert transport.stats['datagrams'] == 1 and link.stats['received'] == 1
        assert link.fileno() == transport.sock.fileno()
    finally:
        link.close()
    assert transport.sock.fileno() == -1


def test_the_transports_names_are_importable_from_the_link_module():
    for name in ('parse_udp_url', 'UrlError', 'UdpUrl', 'MAVROS_MAX_DATAGRAM', 'MAX_DATAGRAM', 'MAX_PACKED_BYTES',
                 'SO_TIMESTAMPNS', 'STAMP_ANCILLARY_BYTES', 'kernel_stamp_ns', 'DEFAULT_BIND_PORT', 'UDP_SCHEMES'):
        assert getattr(mavlink_link, name) is getattr(mavlink_transport, name), name
