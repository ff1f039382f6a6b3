"""mavros home_position: ~home_position/home (HomePosition, latched) from HOME_POSITION.

As mavros's poll timer (started on each connection, stopped by a HOME_POSITION): while none has
arrived, MAV_CMD_GET_HOME_POSITION is sent 10 s after the connection and every 10 s after that. PX4
streams HOME_POSITION at 0.5 Hz, so with PX4 none is sent (the recorded conversations have none).

~home_position/req_update (std_srvs/Trigger) asks for it now, as mavros does through cmd/command:
MAV_CMD_GET_HOME_POSITION, waiting for the ACK; success when the FCU accepted it (false without
the cmd plugin, or while the same command waits). The HOME_POSITION it brings comes on ~home_position/home.
"""

from mavros_msgs.msg import HomePosition as HomePositionMsg
from std_srvs.srv import Trigger, TriggerResponse

from offboard_py import frames
from offboard_py.bridge.command import Busy
from offboard_py.dialect import mavlink

REQUEST_PERIOD_S = 10.0


class HomePosition:
    def __init__(self, bridge):
        self.bridge = bridge
        self.received = False
        self.next_request_s = None  # bridge clock; None while not connected
        self.pub = bridge.publisher('~home_position/home', HomePositionMsg, queue_size=2, latch=True)
        self.update_srv = bridge.service('~home_position/req_update', Trigger, self._req_update)
        bridge.on('HOME_POSITION', self._on_home)
        bridge.on_connection(self._on_connection)
        bridge.every(1.0, self._request)

    def _on_connection(self, connected):
        self.next_request_s = self.bridge.monotonic_s() + REQUEST_PERIOD_S if connected else None

    def _request(self, now_s):
        b = self.bridge
        if b.connected and not self.received and self.next_request_s is not None and now_s >= self.next_request_s:
            self.next_request_s += REQUEST_PERIOD_S
            if b.commands is not None:  # mavros asks through cmd/command, which waits for the ACK
                b.commands.expect(mavlink.MAV_CMD_GET_HOME_POSITION)
            b.send(b.mav.command_long_encode(b.target_system, b.target_component,
                                             mavlink.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0))

    def _req_update(self, _req):
        command_long = self.bridge.command_long
        if command_long is None:
            return TriggerResponse(success=False)
        try:
            success, _result = command_long(mavlink.MAV_CMD_GET_HOME_POSITION, [], confirmation=0)
        except Busy:
            success = False  # mavros's call to cmd/command fails, leaving success false
        return TriggerResponse(success=success)

    def _on_home(self, home):
        self.received = True
        msg = HomePositionMsg()
        msg.header.stamp = self.bridge.now()  # no frame_id, as mavros 1.21 leaves it
        msg.geo.latitude, msg.geo.longitude, msg.geo.altitude = home.latitude * 1e-7, home.longitude * 1e-7, \
            home.altitude * 1e-3
        p = msg.position
        p.x, p.y, p.z = frames.ned_to_enu(home.x, home.y, home.z)
        q = msg.orientation
        q.x, q.y, q.z, q.w = frames.world_orientation_ned_to_enu(frames.wxyz_to_xyzw(*home.q))
        a = msg.approach
        a.x, a.y, a.z = frames.ned_to_enu(home.approach_x, home.approach_y, home.approach_z)
        self.pub.publish(msg)
