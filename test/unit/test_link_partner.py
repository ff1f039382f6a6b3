"""Who a link answers.

The simulated PX4's rule (MavlinkLink(lock_remote=True)), as PX4's mavlink_receiver.cpp has it: the first
datagram's sender is the partner for good, taken before parsing; with a default partner not on this host,
only a datagram at least 3 s after the start is taken, and what comes before is dropped unread.
The bridge's FCU link (peer=(system, component)): only the peer's own frames move the remote, and frames
from other systems are not decoded."""

from offboard_py import wire
from offboard_py.dialect import mavlink
from offboard_py.mavlink_link import MavlinkLink
from offboard_py.testing.reference import px4_figure

from manual_clock import ManualClock

BRIDGE, FLOODER, GCS = ('127.0.0.1', 14540), ('127.0.0.1', 40001), ('127.0.0.1', 40002)


def heartbeat(system_id=255):
    msg = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    return wire.encode(msg, 0, system_id, 190)


def sim_link(remote=('127.0.0.1', 14540), clock=None):
    return MavlinkLink(('127.0.0.1', 0), remote, system_id=1, component_id=1, lock_remote=True,
                       clock=clock or ManualClock())


def test_first_datagram_locks_even_junk_and_nothing_moves_it():
    link = sim_link()
    try:
        heard = []
        link.on('HEARTBEAT', heard.append)
        link.handle_datagram(b'\x00junk', FLOODER)  # junk first: PX4 takes its sender before parsing
        assert link.remote == FLOODER and link.partner_locked
        link.handle_datagram(heartbeat(), BRIDGE)  # a valid frame from elsewhere is read ...
        assert len(heard) == 1 and link.remote == FLOODER  # ... but the replies stay with the partner
        assert link.stats['other_senders'] == 1
    finally:
        link.close()


def test_a_flood_from_another_port_does_not_divert_the_partner():
    link = sim_link()
    try:
        link.handle_datagram(heartbeat(), BRIDGE)
        for _ in range(50):
            link.handle_datagram(heartbeat(42), FLOODER)
        assert link.remote == BRIDGE and link.stats['other_senders'] == 50
    finally:
        link.close()


def test_default_partner_elsewhere_waits_three_seconds():
    clock = ManualClock()
    link = sim_link(remote=('10.0.0.9', 14540), clock=clock)
    try:
        heard = []
        link.on('HEARTBEAT', heard.append)
        link.handle_datagram(heartbeat(), GCS)
        assert link.remote == ('10.0.0.9', 14540) and not heard, 'read before the partner is known'
        assert link.stats['before_partner'] == 1
        lock_after_s = px4_figure('mavlink', 'udp_partner_lock_after_s')
        clock.now_s += lock_after_s - 0.01
        link.handle_datagram(heartbeat(), GCS)
        assert link.remote == ('10.0.0.9', 14540) and not heard, 'PX4 takes no partner before %g s' % lock_after_s
        clock.now_s += 0.01
        link.handle_datagram(heartbeat(), GCS)
        assert link.remote == GCS and len(heard) == 1
    finally:
        link.close()


def test_without_the_lock_a_valid_frame_moves_the_remote_as_mavros_does():
    link = MavlinkLink(('127.0.0.1', 0), ('127.0.0.1', 14580), system_id=1, component_id=1)
    try:
        link.handle_datagram(b'\x00junk', FLOODER)
        assert link.remote == ('127.0.0.1', 14580), 'junk does not move it'
        link.handle_datagram(heartbeat(), FLOODER)
        assert link.remote == FLOODER
    finally:
        link.close()


def test_a_link_with_a_peer_follows_only_the_peer_and_does_not_decode_other_systems():
    """The bridge's FCU link: peer = (target system, target component)."""
    link = MavlinkLink(('127.0.0.1', 0), ('127.0.0.1', 14580), system_id=1, component_id=240, peer=(1, 1))
    try:
        heard, raw = [], []
        link.on('HEARTBEAT', heard.append)
        link.on_frames(raw.append)
        link.handle_datagram(heartbeat(42), FLOODER)  # another system: not decoded, not followed
        assert link.remote == ('127.0.0.1', 14580) and not heard and len(raw) == 1
        assert link.stats['other_system'] == 1
        camera = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
        link.handle_datagram(wire.encode(camera, 0, 1, mavlink.MAV_COMP_ID_CAMERA), FLOODER)
        assert len(heard) == 1 and link.remote == ('127.0.0.1', 14580), 'read, but another component is not the peer'
        autopilot = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 0, 3)
        link.handle_datagram(wire.encode(autopilot, 0, 1, 1), BRIDGE)
        assert link.remote == BRIDGE, 'the peer itself moves it (a restarted FCU on another port)'
    finally:
        link.close()


def test_frames_leave_in_their_sequence_order_whatever_thread_sends_them():
    """The bridge sends from its receive loop, ROS callbacks and service threads; the FCU counts a
    frame that arrives out of its sequence's order as lost (LINK_NODE_STATUS.messages_lost), so the
    link numbers and sends each frame under one lock, as mavconn's single send queue does."""
    import socket
    import threading
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(('127.0.0.1', 0))
    receiver.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    link = MavlinkLink(('127.0.0.1', 0), receiver.getsockname(), system_id=1, component_id=240, learn_remote=False)
    msg = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID,
                                             0, 0, 0, 3)
    try:
        threads = [threading.Thread(target=lambda: [link.send(msg) for _ in range(300)]) for _ in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        receiver.settimeout(1.0)
        seqs = [receiver.recv(300)[4] for _ in range(1200)]
    finally:
        link.close()
        receiver.close()
    steps = [(b - a) & 0xFF for a, b in zip(seqs, seqs[1:])]
    assert steps == [1] * len(steps), 'out of order at %s' % [i for i, s in enumerate(steps) if s != 1][:5]
