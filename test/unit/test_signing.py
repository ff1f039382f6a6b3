"""MAVLink 2 signing in the link layer, frame by frame (no socket traffic: datagrams are fed in).

Rules under test (mavlink.io message signing, PX4's mavlink_sign_control): with a key,
everything sent is signed; when signing is required, unsigned and badly signed frames are
dropped and counted, replays are refused, RADIO_STATUS/ADSB_VEHICLE/COLLISION are taken
unsigned. A forged frame must not be able to lock the genuine sender out.
"""

import os
import stat
import struct

import pytest
from pymavlink.dialects.v10 import common as mavlink1
from pymavlink.dialects.v20 import development as mavlink2

from offboard_py import signing
from offboard_py.mavlink_link import MavlinkLink
from offboard_py.signing import SigningKeyError, read_signing_key, write_signing_key

KEY = bytes(range(1, 33))
OTHER_KEY = bytes(range(101, 133))


@pytest.fixture
def link():
    endpoint = MavlinkLink(('127.0.0.1', 0), None, system_id=1, component_id=1, learn_remote=False)
    endpoint.received = []
    endpoint.on('COMMAND_LONG', endpoint.received.append)
    endpoint.on('RADIO_STATUS', endpoint.received.append)
    endpoint.enable_signing(KEY)
    yield endpoint
    endpoint.close()


def sender(key=None, system_id=255, timestamp=None):
    mav = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=190)
    if key is not None:
        mav.signing.secret_key = key
        mav.signing.sign_outgoing = True
        mav.signing.timestamp = signing.signing_timestamp_now() if timestamp is None else timestamp
    return mav


def arm_frame(mav):
    return mav.command_long_encode(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(mav)


def test_key_file_formats(tmp_path):
    path = tmp_path / 'key.bin'
    path.write_bytes(KEY)
    assert read_signing_key(str(path)) == (KEY, 0)
    path.write_bytes(KEY + struct.pack('<Q', 123456789))
    assert read_signing_key(str(path)) == (KEY, 123456789)
    write_signing_key(str(tmp_path / 'new.bin'), OTHER_KEY, 42)
    assert read_signing_key(str(tmp_path / 'new.bin')) == (OTHER_KEY, 42)
    assert stat.S_IMODE(os.stat(tmp_path / 'new.bin').st_mode) == 0o600, 'a secret is readable by its owner only'


@pytest.mark.parametrize('content, words', [(KEY[:31], '31 bytes'), (KEY + b'\0' * 3, '35 bytes'),
                                            (bytes(32), 'all zeros'), (None, 'No such file')])
def test_bad_key_files_are_named(tmp_path, content, words):
    path = tmp_path / 'key.bin'
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(SigningKeyError) as err:
        read_signing_key(str(path))
    assert str(path) in str(err.value) and words in str(err.value)


def test_signed_frame_accepted_unsigned_and_wrong_key_rejected(link):
    link.handle_datagram(arm_frame(sender(KEY)))
    assert len(link.received) == 1
    link.handle_datagram(arm_frame(sender()))
    link.handle_datagram(arm_frame(sender(OTHER_KEY)))
    assert len(link.received) == 1
    assert link.stats['unsigned_rejected'] == 1 and link.stats['bad_signature'] == 1


def test_mavlink1_cannot_be_signed_so_it_is_rejected(link):
    v1 = mavlink1.MAVLink(None, srcSystem=255, srcComponent=190)
    link.handle_datagram(v1.command_long_encode(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0).pack(v1))
    assert link.received == [] and link.stats['unsigned_rejected'] == 1


def test_replay_is_rejected(link):
    frame = arm_frame(sender(KEY))
    link.handle_datagram(frame)
    link.handle_datagram(frame)
    assert len(link.received) == 1
    assert link.stats['replayed'] == 1 and link.stats['bad_signature'] == 1


def test_stale_new_stream_is_rejected(link):
    two_minutes = 2 * 60 * 100000
    link.handle_datagram(arm_frame(sender(KEY, timestamp=signing.signing_timestamp_now() - two_minutes)))
    assert link.received == [] and link.stats['replayed'] == 1


def test_forged_frame_does_not_lock_out_the_genuine_sender(link):
    """A badly signed frame with a far-future timestamp must not move the stream on
    (pymavlink's own check records the timestamp before it checks the signature)."""
    forger = sender(OTHER_KEY, timestamp=2 ** 47)
    link.handle_datagram(arm_frame(forger))
    link.handle_datagram(arm_frame(sender(KEY)))
    assert len(link.received) == 1, dict(link.stats)


def test_radio_status_is_taken_unsigned(link):
    mav = sender()
    link.handle_datagram(mav.radio_status_encode(200, 190, 0, 100, 90, 0, 0).pack(mav))
    assert [m.get_type() for m in link.received] == ['RADIO_STATUS']


def test_signing_not_required_takes_unsigned(link):
    link.enable_signing(KEY, required=False)
    link.handle_datagram(arm_frame(sender()))
    assert len(link.received) == 1


def test_outgoing_frames_are_signed_with_current_time():
    a = MavlinkLink(('127.0.0.1', 0), None, system_id=1, component_id=1)
    b = MavlinkLink(('127.0.0.1', 0), a.bind, system_id=255, component_id=190)
    try:
        b.enable_signing(KEY)
        a.enable_signing(KEY)
        got = []
        a.on('HEARTBEAT', got.append)
        before = signing.signing_timestamp_now()
        b.send(b.mav.heartbeat_encode(6, 8, 0, 0, 0))
        data, _ = a.sock.recvfrom(1000)
        assert data[2] & mavlink2.MAVLINK_IFLAG_SIGNED
        assert int.from_bytes(data[-12:-6], 'little') >= before
        a.handle_datagram(data)
        assert len(got) == 1
    finally:
        a.close()
        b.close()


def test_disable_signing_sends_unsigned():
    a = MavlinkLink(('127.0.0.1', 0), None, system_id=1, component_id=1)
    b = MavlinkLink(('127.0.0.1', 0), a.bind, system_id=255, component_id=190)
    try:
        b.enable_signing(KEY)
        b.disable_signing()
        b.send(b.mav.heartbeat_encode(6, 8, 0, 0, 0))
        data, _ = a.sock.recvfrom(1000)
        assert not data[2] & mavlink2.MAVLINK_IFLAG_SIGNED
    finally:
        a.close()
        b.close()
