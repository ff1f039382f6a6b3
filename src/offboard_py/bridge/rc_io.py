"""mavros rc_io: ~rc/in (mavros_msgs/RCIn) from RC_CHANNELS: the first chancount channels (us)
and the RSSI. PX4 sends RC_CHANNELS only with an RC link (`sim_px4.py --rc`)."""

from mavros_msgs.msg import RCIn


class RcIo:
    def __init__(self, bridge):
        self.bridge = bridge
        self.pub = bridge.publisher('~rc/in', RCIn)
        bridge.on('RC_CHANNELS', self._on_rc_channels)

    def _on_rc_channels(self, rc):
        if not self.pub.get_num_connections():
            return
        count = min(rc.chancount, 18)
        msg = RCIn(rssi=rc.rssi, channels=[getattr(rc, 'chan%d_raw' % (i + 1)) for i in range(count)])
        msg.header.stamp = self.bridge.fcu_stamp_ms(rc.time_boot_ms)
        self.pub.publish(msg)
