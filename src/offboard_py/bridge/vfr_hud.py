"""mavros vfr_hud: ~vfr_hud (mavros_msgs/VFR_HUD) from VFR_HUD, field for field."""

from mavros_msgs.msg import VFR_HUD as VfrHudMsg


class VfrHud:
    def __init__(self, bridge):
        self.bridge = bridge
        self.pub = bridge.publisher('~vfr_hud', VfrHudMsg)
        bridge.on('VFR_HUD', self._on_vfr_hud, needed=bridge.listened(self.pub))

    def _on_vfr_hud(self, hud):
        msg = VfrHudMsg(airspeed=hud.airspeed, groundspeed=hud.groundspeed, heading=hud.heading,
                        throttle=hud.throttle / 100.0, altitude=hud.alt, climb=hud.climb)
        msg.header.stamp = self.bridge.now()
        self.pub.publish(msg)
