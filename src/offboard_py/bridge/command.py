"""mavros command: ~cmd/arming (CommandBool), ~cmd/takeoff and ~cmd/land (CommandTOL),
~cmd/set_home (CommandHome: MAV_CMD_DO_SET_HOME, confirmation 1, as mavros), ~cmd/command
(CommandLong), ~cmd/command_int (CommandInt), ~cmd/command_ack (CommandAck: a COMMAND_ACK to the
FCU, success=true and result ACCEPTED once sent, as mavros); and sys_status's
~set_message_interval (MessageInterval) and ~set_stream_rate (StreamRate), which send commands.

Each COMMAND_LONG waits for the matching COMMAND_ACK up to cmd/command_ack_timeout:
success = ACCEPTED, result = the ACK's MAV_RESULT; no ACK gives success=false,
result=MAV_RESULT_FAILED. A second call for a command that is still waiting fails as a
service call, as in mavros. Different commands may wait at once. As in mavros 1.x:
- cmd/command with broadcast=true goes to system 0, component 0 with confirmation 0 whatever the
  request says (command.cpp's confirmation_fixed), and waits for nothing (success=true); like any
  call it fails while the same command waits for its ACK;
- cmd/command_int sends COMMAND_INT and waits for nothing (success=true once sent);
- set_message_interval sends MAV_CMD_SET_MESSAGE_INTERVAL (rate > 0: 1e6/rate us, 0: the
  default rate, < 0: off) as mavros's sys_status does, through cmd/command: it waits for the ACK,
  and answers success=true whatever came (an ACK with any result, or none), since mavros's success
  is that its call to cmd/command went through; the call fails only while the same command waits;
- set_stream_rate sends the old REQUEST_DATA_STREAM (PX4 ignores it) and answers nothing;
- a COMMAND_ACK nobody waits for is logged, at most every 10 s ("CMD: Unexpected command 520,
  result 0" once PX4 answers the AUTOPILOT_VERSION request sys_status sends on connection).
"""

import threading
import time

import rospy
from mavros_msgs.srv import (CommandAck, CommandAckResponse, CommandBool, CommandBoolResponse, CommandHome,
                             CommandHomeResponse, CommandInt, CommandIntResponse, CommandLong, CommandLongResponse,
                             CommandTOL, CommandTOLResponse, MessageInterval, MessageIntervalResponse, StreamRate,
                             StreamRateResponse)

from offboard_py.bridge import c_casts
from offboard_py.dialect import mavlink

CONFIRMATION = 1  # what mavros's cmd plugin puts in COMMAND_LONG.confirmation for these services


class Busy(Exception):
    """The same command is already waiting for its COMMAND_ACK."""


UNEXPECTED_LOG_PERIOD_S = 10.0  # mavros: ROS_WARN_THROTTLE_NAMED(10, "cmd", "CMD: Unexpected command ...")


class CommandWaiter:
    """COMMAND_LONG requests waiting for their COMMAND_ACK, at most one per command id."""

    def __init__(self, clock=time.monotonic):
        self._lock = threading.Lock()
        self._pending = {}  # command -> [event, result]
        self._clock = clock
        self.unexpected = 0  # ACKs for no waiting command
        self._logged_s = None
        self._expected = set()  # commands sent without waiting whose next ACK is expected all the same

    def begin(self, cmd):
        with self._lock:
            if cmd in self._pending:
                raise Busy('command %d is already waiting for its COMMAND_ACK' % cmd)
            entry = [threading.Event(), None]
            self._pending[cmd] = entry
            return entry

    def waiting(self, cmd):
        return cmd in self._pending

    def end(self, cmd):
        with self._lock:
            self._pending.pop(cmd, None)

    def expect(self, cmd):
        """The next ACK of `cmd` is expected though nothing waits for it: a plugin sent the command
        itself where mavros's plugin asks through cmd/command and waits (home_position)."""
        with self._lock:
            self._expected.add(cmd)

    def on_ack(self, msg):
        with self._lock:
            entry = self._pending.get(msg.command)
            if entry is None:
                if msg.command in self._expected:
                    self._expected.discard(msg.command)
                    return
                self.unexpected += 1
                now_s = self._clock()
                if self._logged_s is None or now_s - self._logged_s >= UNEXPECTED_LOG_PERIOD_S:
                    self._logged_s = now_s
                    rospy.logwarn('CMD: Unexpected command %d, result %d', msg.command, msg.result)
            elif not entry[0].is_set():
                entry[1] = msg.result
                entry[0].set()


class Command:
    def __init__(self, bridge):
        self.bridge = bridge
        self.waiter = CommandWaiter(clock=bridge.monotonic_s)  # the throttle on ROS time, as mavros's
        bridge.provide('commands', self.waiter)  # for plugins that send a command themselves
        bridge.provide('command_long', self.command_long)  # for plugins that ask through cmd/command, as mavros's
        self.timeout_s = bridge.cfg['cmd/command_ack_timeout']
        bridge.on('COMMAND_ACK', self.waiter.on_ack)
        self.services = [
            bridge.service('~cmd/arming', CommandBool, self._arming),
            bridge.service('~cmd/takeoff', CommandTOL, self._takeoff),
            bridge.service('~cmd/land', CommandTOL, self._land),
            bridge.service('~cmd/command', CommandLong, self._command),
            bridge.service('~cmd/command_int', CommandInt, self._command_int),
            bridge.service('~cmd/command_ack', CommandAck, self._command_ack),
            bridge.service('~cmd/set_home', CommandHome, self._set_home),
            bridge.service('~set_message_interval', MessageInterval, self._set_message_interval),
            bridge.service('~set_stream_rate', StreamRate, self._set_stream_rate),
        ]

    def command_long(self, cmd, params, confirmation=CONFIRMATION):
        """Send COMMAND_LONG and wait for its ACK: (success, MAV_RESULT); Busy if already waiting."""
        b = self.bridge
        entry = self.waiter.begin(cmd)
        try:
            params = list(params) + [0.0] * (7 - len(params))
            b.send(b.mav.command_long_encode(b.target_system, b.target_component, cmd, confirmation, *params))
            if not b.wait(entry[0], self.timeout_s):
                rospy.logwarn('CMD: command %d: no COMMAND_ACK within %.1f s', cmd, self.timeout_s)
                return False, mavlink.MAV_RESULT_FAILED
            return entry[1] == mavlink.MAV_RESULT_ACCEPTED, entry[1]
        finally:
            self.waiter.end(cmd)

    def _call(self, cmd, params, confirmation=CONFIRMATION):
        try:
            return self.command_long(cmd, params, confirmation)
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

    def _set_home(self, req):
        success, result = self._call(mavlink.MAV_CMD_DO_SET_HOME, [1.0 if req.current_gps else 0.0, 0.0, 0.0, req.yaw,
                                                                   req.latitude, req.longitude, req.altitude])
        return CommandHomeResponse(success=success, result=result)

    def _command_ack(self, req):
        b = self.bridge
        # the service's uint32 result_param2 into MAVLink's int32, as mavros's assignment wraps it
        b.send(b.mav.command_ack_encode(req.command, req.result, req.progress, c_casts.int32_from_int(req.result_param2),
                                        b.target_system, b.target_component))
        return CommandAckResponse(success=True, result=mavlink.MAV_RESULT_ACCEPTED)

    def _command(self, req):
        params = (req.param1, req.param2, req.param3, req.param4, req.param5, req.param6, req.param7)
        if req.broadcast:
            if self.waiter.waiting(req.command):  # mavros looks for it before it looks at broadcast
                raise rospy.ServiceException('command %d is already waiting for its COMMAND_ACK' % req.command)
            b = self.bridge
            b.send(b.mav.command_long_encode(0, 0, req.command, 0, *params))  # a broadcast is never confirmed
            return CommandLongResponse(success=True, result=mavlink.MAV_RESULT_ACCEPTED)
        success, result = self._call(req.command, params, req.confirmation)
        return CommandLongResponse(success=success, result=result)

    def _command_int(self, req):
        b = self.bridge
        target = (0, 0) if req.broadcast else (b.target_system, b.target_component)
        sent = b.send(b.mav.command_int_encode(*target, req.frame, req.command, req.current, req.autocontinue,
                                               req.param1, req.param2, req.param3, req.param4, req.x, req.y, req.z))
        return CommandIntResponse(success=bool(sent))

    def _set_message_interval(self, req):
        if req.message_rate < 0:
            interval_us = -1.0
        elif req.message_rate == 0:
            interval_us = 0.0
        else:
            interval_us = 1e6 / req.message_rate
        try:
            self.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, [req.message_id, interval_us], confirmation=0)
        except Busy as err:
            # mavros's cmd/command call returns false here, and set_message_interval with it
            rospy.logerr('SetMessageInterval: command plugin service call failed!')
            raise rospy.ServiceException(str(err))
        return MessageIntervalResponse(success=True)

    def _set_stream_rate(self, req):
        b = self.bridge
        b.send(b.mav.request_data_stream_encode(b.target_system, b.target_component, req.stream_id, req.message_rate,
                                                1 if req.on_off else 0))
        return StreamRateResponse()
