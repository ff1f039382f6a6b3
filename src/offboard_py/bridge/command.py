"""mavros command: ~cmd/arming (CommandBool), ~cmd/takeoff and ~cmd/land (CommandTOL).

Each sends one COMMAND_LONG and waits for the matching COMMAND_ACK up to
cmd/command_ack_timeout: success = ACCEPTED, result = the ACK's MAV_RESULT; no ACK gives
success=false, result=MAV_RESULT_FAILED. A second call for a command that is still waiting
fails as a service call, as in mavros. Different commands may wait at once.
"""

import threading

import rospy
from mavros_msgs.srv import CommandBool, CommandBoolResponse, CommandTOL, CommandTOLResponse

from offboard_py.dialect import mavlink

CONFIRMATION = 1  # what mavros's cmd plugin puts in COMMAND_LONG.confirmation for these services


class Busy(Exception):
    """The same command is already waiting for its COMMAND_ACK."""


class CommandWaiter:
    """COMMAND_LONG requests waiting for their COMMAND_ACK, at most one per command id."""

    def __init__(self):
        self._lock = threading.Lock()
        self._pending = {}  # command -> [event, result]

    def begin(self, cmd):
        with self._lock:
            if cmd in self._pending:
                raise Busy('command %d is already waiting for its COMMAND_ACK' % cmd)
            entry = [threading.Event(), None]
            self._pending[cmd] = entry
            return entry

    def end(self, cmd):
        with self._lock:
            self._pending.pop(cmd, None)

    def on_ack(self, msg):
        with self._lock:
            entry = self._pending.get(msg.command)
            if entry is not None and not entry[0].is_set():
                entry[1] = msg.result
                entry[0].set()


class Command:
    def __init__(self, bridge):
        self.bridge = bridge
        self.waiter = CommandWaiter()
        self.timeout_s = bridge.cfg['cmd/command_ack_timeout']
        bridge.on('COMMAND_ACK', self.waiter.on_ack)
        self.services = [
            bridge.service('~cmd/arming', CommandBool, self._arming),
            bridge.service('~cmd/takeoff', CommandTOL, self._takeoff),
            bridge.service('~cmd/land', CommandTOL, self._land),
        ]

    def command_long(self, cmd, params):
        """Send COMMAND_LONG and wait for its ACK: (success, MAV_RESULT); Busy if already waiting."""
        b = self.bridge
        entry = self.waiter.begin(cmd)
        try:
            params = list(params) + [0.0] * (7 - len(params))
            b.send(b.mav.command_long_encode(b.target_system, b.target_component, cmd, CONFIRMATION, *params))
            if not entry[0].wait(self.timeout_s):
                rospy.logwarn('CMD: command %d: no COMMAND_ACK within %.1f s', cmd, self.timeout_s)
                return False, mavlink.MAV_RESULT_FAILED
            return entry[1] == mavlink.MAV_RESULT_ACCEPTED, entry[1]
        finally:
            self.waiter.end(cmd)

    def _call(self, cmd, params):
        try:
            return self.command_long(cmd, params)
        except Busy as err:
            raise rospy.ServiceException(str(err))

    def _arming(self, req):
        success, result = self._call(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, [1.0 if req.value else 0.0])
        return CommandBoolResponse(success=success, result=result)

    def _takeoff(self, req):
        success, result = self._call(mavlink.MAV_CMD_NAV_TAKEOFF, [req.min_pitch, 0.0, 0.0, req.yaw, req.latitude,
                                                                   req.longitude, req.altitude])
        return CommandTOLResponse(success=success, result=result)

    def _land(self, req):
        success, result = self._call(mavlink.MAV_CMD_NAV_LAND, [0.0, 0.0, 0.0, req.yaw, req.latitude,
                                                                req.longitude, req.altitude])
        return CommandTOLResponse(success=success, result=result)
