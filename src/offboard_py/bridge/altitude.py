"""mavros altitude: ~altitude (mavros_msgs/Altitude) from ALTITUDE."""

from mavros_msgs.msg import Altitude as AltitudeMsg


class Altitude:
    def __init__(self, bridge):
        self.bridge = bridge
        self.frame_id = bridge.cfg['local_position/frame_id']
        self.pub = bridge.publisher('~altitude', AltitudeMsg)
        bridge.on('ALTITUDE', self._on_altitude, needed=bridge.listened(self.pub))

    def _on_altitude(self, alt):
        msg = AltitudeMsg()
        msg.header.stamp, msg.header.frame_id = self.bridge.fcu_stamp_us(alt.time_usec), self.frame_id
        msg.monotonic, msg.amsl, msg.local = alt.altitude_monotonic, alt.altitude_amsl, alt.altitude_local
        msg.relative, msg.terrain = alt.altitude_relative, alt.altitude_terrain
        msg.bottom_clearance = alt.bottom_clearance
        self.pub.publish(msg)
