"""mavros rc_io: ~rc/in (mavros_msgs/RCIn) from RC_CHANNELS: the first chancount channels (us)
and the RSSI. PX4 sends RC_CHANNELS only with an RC link (`sim_px4.py --rc`).
~rc/out (mavros_msgs/RCOut) from SERVO_OUTPUT_RAW (PX4: 10 Hz), as mavros 1.21's rc_io: the
outputs of every port seen so far, 16 a port (8 from a MAVLink 1 frame) at port x 16, stamped
with the message's FCU time; forgotten when the connection changes."""

from mavros_msgs.msg import RCIn, RCOut

from offboard_py import wire


class RcIo:
    def __init__(self, bridge):
        self.bridge = bridge
        self.pub = bridge.publisher('~rc/in', RCIn)
        bridge.on('RC_CHANNELS', self._on_rc_channels)
        self.out_pub = bridge.publisher('~rc/out', RCOut)
        self.port_frames = {}  # port -> its latest SERVO_OUTPUT_RAW frame, kept as mavros keeps raw_rc_out
        bridge.on_raw('SERVO_OUTPUT_RAW', self._on_servo_output_raw)
        bridge.on_connection(lambda _connected: self.port_frames.clear())

    def _on_servo_output_raw(self, frame):
        header = wire.HEADER_V2 if frame[0] == wire.MAGIC_V2 else wire.HEADER_V1
        # the port byte follows time_usec and servo1..8; MAVLink 2 trims a payload's trailing zeros
        port = frame[header + 20] if frame[1] > 20 else 0
        self.port_frames[port] = frame
        if not self.out_pub.get_num_connections():
            return
        outputs = []
        for each, kept in sorted(self.port_frames.items()):
            count = 16 if kept[0] == wire.MAGIC_V2 else 8
            out = wire.decode_checked(kept)
            outputs += [0] * max(0, (each + 1) * count - len(outputs))
            outputs[each * count:(each + 1) * count] = [getattr(out, 'servo%d_raw' % (i + 1)) for i in range(count)]
            if each == port:
                stamp = self.bridge.fcu_stamp_us(out.time_usec)
        msg = RCOut(channels=outputs)
        msg.header.stamp = stamp
        self.out_pub.publish(msg)

    def _on_rc_channels(self, rc):
        if not self.pub.get_num_connections():
            return
        count = min(rc.chancount, 18)
        msg = RCIn(rssi=rc.rssi, channels=[getattr(rc, 'chan%d_raw' % (i + 1)) for i in range(count)])
        msg.header.stamp = self.bridge.fcu_stamp_ms(rc.time_boot_ms)
        self.pub.publish(msg)
