"""mavros's raw MAVLink topics: mavlink/from and mavlink/to (mavros_msgs/Mavlink), beside the
node (/mavlink/from for /mavros, /uav0/mavlink/from for /uav0/mavros).

- Every valid frame from the FCU, of any type (also those no plugin reads), is published on
  mavlink/from when someone listens, with mavros's layout: header fields, the payload as
  little-endian uint64 words (zero padded), the signature if signed; framing_status OK.
- A Mavlink message on mavlink/to is sent to the FCU as the frame it describes, checksum and
  all, as mavros does (no re-numbering: a wrong checksum is the sender's to own). A message
  whose magic, length or payload does not make a frame is refused and logged.
"""

import struct

import rospy
from mavros_msgs.msg import Mavlink

from offboard_py import wire


def frame_to_msg(frame, stamp):
    msg = Mavlink(framing_status=Mavlink.FRAMING_OK, magic=frame[0], len=frame[1])
    msg.header.stamp = stamp
    if frame[0] == wire.MAGIC_V2:
        msg.incompat_flags, msg.compat_flags, msg.seq, msg.sysid, msg.compid = frame[2:7]
        msg.msgid = frame[7] | frame[8] << 8 | frame[9] << 16
        header = wire.HEADER_V2
    else:
        msg.seq, msg.sysid, msg.compid, msg.msgid = frame[2:6]
        header = wire.HEADER_V1
    payload = bytes(frame[header:header + frame[1]])
    payload += b'\x00' * (-len(payload) % 8)
    msg.payload64 = list(struct.unpack('<%dQ' % (len(payload) // 8), payload))
    msg.checksum = struct.unpack_from('<H', frame, header + frame[1])[0]
    if frame[0] == wire.MAGIC_V2 and msg.incompat_flags & wire.IFLAG_SIGNED:
        msg.signature = list(frame[header + frame[1] + 2:])
    return msg


def msg_to_frame(msg):
    """The frame bytes a Mavlink message describes; ValueError naming what does not fit."""
    payload = struct.pack('<%dQ' % len(msg.payload64), *msg.payload64)
    if len(payload) < msg.len or len(payload) >= msg.len + 8:
        raise ValueError('payload64 holds %d bytes for len %d' % (len(payload), msg.len))
    body = payload[:msg.len]
    if msg.magic == wire.MAGIC_V2:
        signed = bool(msg.incompat_flags & wire.IFLAG_SIGNED)
        if signed and len(msg.signature) != wire.SIGNATURE_LEN:
            raise ValueError('signed frame with a %d-byte signature' % len(msg.signature))
        head = struct.pack('<BBBBBBBHB', msg.magic, msg.len, msg.incompat_flags, msg.compat_flags, msg.seq,
                           msg.sysid, msg.compid, msg.msgid & 0xFFFF, msg.msgid >> 16)
        return head + body + struct.pack('<H', msg.checksum) + (bytes(msg.signature) if signed else b'')
    if msg.magic == wire.MAGIC_V1:
        if msg.msgid > 255:
            raise ValueError('message id %d in a MAVLink 1 frame' % msg.msgid)
        return struct.pack('<BBBBBB', msg.magic, msg.len, msg.seq, msg.sysid, msg.compid, msg.msgid) + body + \
            struct.pack('<H', msg.checksum)
    raise ValueError('magic 0x%02X is neither MAVLink 2 (0xFD) nor 1 (0xFE)' % msg.magic)


class MavlinkPassthrough:
    def __init__(self, bridge):
        self.bridge = bridge
        self.pub = bridge.publisher('mavlink/from', Mavlink, queue_size=100)
        self.sub = bridge.subscriber('mavlink/to', Mavlink, self._to_fcu)
        bridge.on_frames(self._from_fcu, needed=bridge.listened(self.pub))

    def _from_fcu(self, frame):
        self.pub.publish(frame_to_msg(frame, self.bridge.now()))

    def _to_fcu(self, msg):
        try:
            frame = msg_to_frame(msg)
        except (ValueError, struct.error) as err:
            rospy.logerr('mavlink/to: message %d not sent: %s', msg.msgid, err)
            return
        self.bridge.send_frame(frame)
