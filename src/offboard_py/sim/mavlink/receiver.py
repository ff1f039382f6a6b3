"""The simulated PX4's MAVLink receiver, as PX4's MavlinkReceiver (src/modules/mavlink/mavlink_receiver.cpp):
a message from a link becomes a vehicle command (sim.mavlink.vehicle_commands), a setpoint
(sim.offboard_input), a parameter or mission request (sim.mavlink.parameters, sim.mavlink.mission_manager),
with PX4's receiver checks first (the target, the sentinels of a command in the wrong message, the frame of
a COMMAND_INT, commands from the autopilot's own ids). Every COMMAND_LONG/COMMAND_INT gets a COMMAND_ACK;
what is addressed to another system is ignored. What changes the vehicle is taken from the allowed systems
only (--allowed-systems); reading is open to anyone. The receiver answers message intervals and requests
itself, as PX4's does; the answer goes back on the link its request came from: every handler is
handler(msg, link), given the link the message came from, and passes it on to what answers."""

import logging
import math
import struct

from offboard_py import px4_modes
from offboard_py.dialect import MAV_CMD_INJECT_FAILURE, mavlink
from offboard_py.signing import write_signing_key
from offboard_py.sim import logged_topics, manual_control, offboard_input
from offboard_py.sim.mavlink import streams
from offboard_py.sim.mavlink.command_sender import ACK_DELAY_S
from offboard_py.sim.mavlink.log_handler import LogHandler
from offboard_py.sim.mavlink.timesync import TimesyncAnswer
from offboard_py.sim.mavlink.vehicle_commands import (ACCEPTED, DENIED, FAILED, UNSUPPORTED, VehicleCommands,
                                                      c_int_round, command_position)

log = logging.getLogger('offboard_py.sim')

UNSUPPORTED_MAV_FRAME = mavlink.MAV_RESULT_UNSUPPORTED_MAV_FRAME
# PX4's receiver's sentinels of a command sent in the wrong message: INT32_MAX in COMMAND_LONG's float
# param5/param6 (the floats next to it on either side, as PX4 compares), NaN's float bits in COMMAND_INT's x/y
INT32_MAX_AS_FLOAT = (struct.unpack('<f', struct.pack('<I', 0x4EFFFFFF))[0],
                      struct.unpack('<f', struct.pack('<I', 0x4F000001))[0])
NAN_AS_INT32 = 0x7FF80000
# What REQUEST_MESSAGE's older, dedicated commands ask for
REQUESTED_BY_COMMAND = {mavlink.MAV_CMD_GET_HOME_POSITION: mavlink.MAVLINK_MSG_ID_HOME_POSITION,
                        mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                        mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION: mavlink.MAVLINK_MSG_ID_PROTOCOL_VERSION}
# Commands mavlink_receiver.cpp answers itself or passes on before its own-id check
# (handle_message_command_both): these are taken even from a sender with the autopilot's ids
RECEIVER_COMMANDS = frozenset((
    mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION,
    mavlink.MAV_CMD_GET_HOME_POSITION, mavlink.MAV_CMD_REQUEST_FLIGHT_INFORMATION,
    mavlink.MAV_CMD_REQUEST_STORAGE_INFORMATION, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
    mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, mavlink.MAV_CMD_REQUEST_MESSAGE, MAV_CMD_INJECT_FAILURE,
    mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE))


class Receiver:
    """What `px4` (sim.autopilot.SimulatedPx4) takes from its links."""

    def __init__(self, px4):
        self.px4 = px4
        self.flight, self.origin, self.params, self.mav = px4.flight, px4.origin, px4.params, px4.mav
        self.system_id, self.counters, self.links = px4.system_id, px4.counters, px4.links
        self.streams, self.telemetry, self.link_counters = px4.streams, px4.telemetry, px4.link_counters
        self.mission_manager, self.parameters = px4.mission_manager, px4.parameters
        self.command_sender = px4.command_sender
        # the flight stack's commands: handler(msg, now) (sim.mavlink.vehicle_commands)
        self.commands = VehicleCommands(px4).table
        # what the receiver answers itself, on the request's link: handler(msg, link, now); taken before the above
        self.receiver_commands = {
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: self._cmd_set_message_interval,
            mavlink.MAV_CMD_GET_MESSAGE_INTERVAL: self._cmd_get_message_interval,
            mavlink.MAV_CMD_REQUEST_MESSAGE: self._cmd_request_message,
            mavlink.MAV_CMD_GET_HOME_POSITION: self._cmd_request_message,
            mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._cmd_request_message,
            mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION: self._cmd_request_message,
        }
        # PX4's MavlinkLogHandler, one per link (sim.mavlink.log_handler); the autopilot gives each its turn
        self.log_handlers = {link: LogHandler(px4.log_root, self.mav, link) for link in self.links}
        for link in self.links:
            self._register_on(link)

    def _register_on(self, link):
        def on(msg_type, handler):
            """handler(msg, link) for each `msg_type` from `link`."""
            link.on(msg_type, lambda msg: handler(msg, link))

        def control(msg_type, handler):
            on(msg_type, self._control(msg_type, handler))
        # what changes the vehicle (commands, setpoints, parameters, missions, the key) is
        # taken from the allowed systems only; reading is open to anyone
        control('COMMAND_LONG', self._on_command)
        control('COMMAND_INT', self._on_command)
        control('SET_MODE', self._on_set_mode)
        control('SET_POSITION_TARGET_LOCAL_NED', self._on_setpoint)
        control('SET_POSITION_TARGET_GLOBAL_INT', self._on_setpoint)
        control('SET_ATTITUDE_TARGET', self._on_setpoint)
        control('PARAM_SET', self.parameters.on_set)
        control('SETUP_SIGNING', self._on_setup_signing)
        control('MANUAL_CONTROL', self._on_manual_control)
        control('FOLLOW_TARGET', self._on_follow_target)
        control('MISSION_COUNT', self._mission(self.mission_manager.on_count))
        control('MISSION_ITEM_INT', self._mission(self.mission_manager.on_item))
        control('MISSION_ITEM', self._mission(self.mission_manager.on_item))
        control('MISSION_CLEAR_ALL', self._mission(self.mission_manager.on_clear_all))
        control('MISSION_SET_CURRENT', self._mission(lambda m, t, _link: self._set_current(m.seq)))
        on('COMMAND_ACK', lambda msg, _link: self.command_sender.on_command_ack(msg))
        on('HEARTBEAT', self._on_heartbeat)
        on('PARAM_REQUEST_LIST', self.parameters.on_request_list)
        on('PARAM_REQUEST_READ', self.parameters.on_request_read)
        on('MISSION_REQUEST_LIST', self._mission(self.mission_manager.on_request_list))
        on('MISSION_REQUEST_INT', self._mission(self.mission_manager.on_request))
        on('MISSION_REQUEST', self._mission(self.mission_manager.on_request))
        on('MISSION_ACK', self._mission(self.mission_manager.on_ack))
        on('TIMESYNC', self._on_timesync)
        on('PING', self._on_ping)
        # the link's own log handler answers on it
        log_handler = self.log_handlers[link]
        on('LOG_REQUEST_LIST', lambda msg, _link: log_handler.on_request_list(msg))
        on('LOG_REQUEST_DATA', lambda msg, _link: log_handler.on_request_data(msg))
        on('LOG_REQUEST_END', lambda msg, _link: log_handler.on_request_end(msg))
        control('LOG_ERASE', lambda msg, _link: log_handler.on_erase(msg))

    def _control(self, msg_type, handler):
        """`handler` for the allowed systems only."""
        def handle(msg, link):
            if not self.px4.allowed_systems or msg.get_srcSystem() in self.px4.allowed_systems:
                handler(msg, link)
                return
            self.counters['not_allowed'] += 1
            n = self.counters['not_allowed']
            if n <= 3 or n % 100 == 0:
                log.warning('ignored %s from system %d: not in the allowed systems %s (%d ignored so far)',
                            msg_type, msg.get_srcSystem(), sorted(self.px4.allowed_systems), n)
        return handle

    def _mission(self, handler):
        """`handler` for what PX4's mission manager takes (sim.mavlink.mission_manager: its own system id only)."""
        def handle(msg, link):
            if self.mission_manager.for_me(msg):
                handler(msg, self.px4.t(), link)
            else:
                self.counters['ignored_other_system'] += 1
        return handle

    def _ack(self, msg, link, command, result, delay_s=ACK_DELAY_S):
        """COMMAND_ACK on the request's `link`, `delay_s` (simulated) after now (sim.mavlink.command_sender)."""
        self.command_sender.ack(link, msg, command, result, delay_s)
        if self.px4.logger is not None:
            self.px4.logger.on_vehicle_command_ack(logged_topics.vehicle_command_ack(
                self.px4.t(), command, result, (msg.get_srcSystem(), msg.get_srcComponent())))

    def _on_heartbeat(self, msg, link):
        self.px4.texts.on_heartbeat(link, msg, self.px4.t())
        if msg.type == mavlink.MAV_TYPE_GCS and msg.get_srcSystem() != self.system_id:
            self.flight.on_gcs_heartbeat(self.px4.t())  # handle_message_heartbeat: telemetry_status's GCS

    def _on_manual_control(self, msg, _link):
        """A ground station's joystick (handle_message_manual_control: for this system or for all, target 0), its
        sticks scaled as PX4 scales them (sim.manual_control.from_mavlink)."""
        if msg.target in (0, self.system_id):
            sticks = manual_control.from_mavlink(msg.x, msg.y, msg.z, msg.r)
            self.flight.on_manual_control(self.px4.t(), sticks)

    def _on_follow_target(self, msg, _link):
        """The target of follow-me (handle_message_follow_target: degE7, m AMSL, NED m/s; no target fields)."""
        values = (msg.lat, msg.lon, msg.alt) + tuple(msg.vel)
        if not all(math.isfinite(v) for v in values):
            log.warning('FOLLOW_TARGET from system %d ignored: a field is not a number (%s)', msg.get_srcSystem(),
                        values)
            return
        position = self.origin.to_local(msg.lat * 1e-7, msg.lon * 1e-7, msg.alt)
        self.flight.on_follow_target(position, tuple(msg.vel), self.px4.t())

    def _on_set_mode(self, msg, link):
        """PX4's receiver turns SET_MODE into a DO_SET_MODE vehicle command for target_system, and the
        commander takes a command for its own system or for all (0), as for COMMAND_LONG."""
        if self.px4.logger is not None:  # published whatever the target
            self.px4.logger.on_vehicle_command(logged_topics.set_mode_message(msg, self.px4.t()))
        if msg.target_system not in (0, self.system_id):
            self.counters['ignored_other_system'] += 1
            return
        main, sub = px4_modes.split(msg.custom_mode)
        result = self.flight.request_base_mode(msg.base_mode, main, sub, self.px4.t())
        # PX4 answers the SET_MODE message as DO_SET_MODE
        self._ack(msg, link, mavlink.MAV_CMD_DO_SET_MODE, result)
        self.px4.say_events()

    def _refused_before_dispatch(self, msg):
        """What PX4's mavlink_receiver.cpp refuses before it looks at the target or the command: a
        COMMAND_LONG with param5 and param6 both INT32_MAX (an integer sentinel sent as a float) and a
        COMMAND_INT with x and y both 0x7ff80000 (a float NaN sent as an integer) are DENIED; a
        COMMAND_INT in any frame but MAV_FRAME_GLOBAL_INT is UNSUPPORTED_MAV_FRAME. None: go on."""
        if msg.get_type() == 'COMMAND_LONG':
            if INT32_MAX_AS_FLOAT[0] <= msg.param5 <= INT32_MAX_AS_FLOAT[1] and \
                    INT32_MAX_AS_FLOAT[0] <= msg.param6 <= INT32_MAX_AS_FLOAT[1]:
                return DENIED
            return None
        if msg.x == NAN_AS_INT32 and msg.y == NAN_AS_INT32:
            return DENIED
        if msg.frame != mavlink.MAV_FRAME_GLOBAL_INT:
            return UNSUPPORTED_MAV_FRAME
        return None

    def _on_command(self, msg, link):
        refused = self._refused_before_dispatch(msg)
        if refused is not None:
            self._ack(msg, link, msg.command, refused)
            return
        if not self.px4.for_me(msg):
            return
        if msg.command not in RECEIVER_COMMANDS and \
                (msg.get_srcSystem(), msg.get_srcComponent()) == (self.system_id, 1):
            # handle_message_command_both: a command for the commander from our own system and component
            # is ignored, unanswered ("ignoring CMD with same SYS/COMP")
            self.counters['ignored_own_id'] = self.counters.get('ignored_own_id', 0) + 1
            return
        if self.px4.logger is not None:
            published = logged_topics.command_message(msg, self.px4.t(), self.params)
            if published is not None:
                self.px4.logger.on_vehicle_command(published)
        if msg.command == mavlink.MAV_CMD_DO_SET_MODE:
            # PX4's MAVLink module acknowledges at once, then the commander gives its own result:
            # two COMMAND_ACK(176) 1-8 ms apart (reference/px4-sitl-measured.md, section 4)
            self._ack(msg, link, msg.command, ACCEPTED, delay_s=0.0)
        if msg.command in self.receiver_commands:
            result = self.receiver_commands[msg.command](msg, link, self.px4.t())
        else:
            handler = self.commands.get(msg.command)
            result = handler(msg, self.px4.t()) if handler else UNSUPPORTED
        if result is not None:
            self._ack(msg, link, msg.command, result)
        self.px4.say_events()

    def _cmd_set_message_interval(self, msg, link, now):
        """On the link the command came from, as PX4 (each MAVLink instance has its streams), with
        MavlinkReceiver::set_message_interval's reading: the id is (int)(param1 + 0.5); param3, param4
        and param7 (the response target) must round to 0; an interval within 1e-5 us of 0, or NaN,
        is the stream's default, a negative one stops it."""
        unsupported = (msg.param3, msg.param4, command_position(msg)[2])  # param7: the response target
        if not all(not math.isfinite(p) or int(p + 0.5) == 0 for p in unsupported):
            return FAILED
        msg_id = c_int_round(msg.param1)
        interval = msg.param2
        if not math.isfinite(interval) or abs(interval) <= 1e-5:
            interval = 0  # the default rate
        ok = msg_id is not None and self.streams[link].set_interval(msg_id, interval, now)
        return ACCEPTED if ok else FAILED

    def _cmd_get_message_interval(self, msg, link, now):
        """MESSAGE_INTERVAL for (int)(param1 + 0.5): a stream not running on this link is -1, as PX4
        (MavlinkReceiver::get_message_interval finds no stream of that id)."""
        msg_id = c_int_round(msg.param1)
        interval = -1 if msg_id is None else self.streams[link].interval_us(msg_id)
        link.send(self.mav.message_interval_encode((msg_id or 0) & 0xFFFF, -1 if interval == 0 else interval))
        return ACCEPTED

    def _cmd_request_message(self, msg, link, now):
        """PX4 answers DENIED for what it cannot send (an unknown id, home before there is one)."""
        msg_id = REQUESTED_BY_COMMAND.get(msg.command, msg.param1)
        if msg_id == mavlink.MAVLINK_MSG_ID_AVAILABLE_MODES:
            return self._available_modes(msg.param2, link)
        name = streams.NAMES_BY_ID.get(int(msg_id)) if math.isfinite(msg_id) else None
        reply = self.build(name, link, now) if name else None
        if reply is None:
            return DENIED
        link.send(reply)
        return ACCEPTED

    def _available_modes(self, which, link):
        """AVAILABLE_MODES as PX4's stream answers a request (reference/px4-sitl-measured.md, section
        3): param2 0 all of them, N mode N only, each in a message of its own, before the ACK. PX4's
        MavlinkStreamAvailableModes::request_message refuses N above the number of modes (DENIED,
        nothing sent) and takes a negative N without sending anything (ACCEPTED); a NaN names no mode
        (DENIED)."""
        if not math.isfinite(which):
            return DENIED
        index, modes = int(round(which)), px4_modes.AVAILABLE_MODES
        if index > len(modes):
            return DENIED
        chosen = range(1, len(modes) + 1) if index == 0 else [index] if index > 0 else []
        for i in chosen:
            mode = modes[i - 1]
            link.send(self.mav.available_modes_encode(len(modes), i, mode.standard_mode, mode.custom_mode,
                                                   mode.properties, mode.mode_name.encode('ascii')))
        return ACCEPTED

    def build(self, name, link, now):
        """The message `name` as `link` sends it now (None: nothing to say)."""
        if name in streams.PER_LINK:
            return self.telemetry.link_node_status(self.link_counters[link], now)
        return self.telemetry.build(name, self.flight.status(now), now)

    def _on_setpoint(self, msg, link):
        """The three setpoint messages PX4 takes as the offboard signal (sim.offboard_input)."""
        if not self.px4.for_me(msg):
            return
        kind = msg.get_type()
        yaw = self.flight.vehicle.yaw
        try:
            if kind == 'SET_POSITION_TARGET_LOCAL_NED':
                sp = offboard_input.from_message(msg, yaw)
            elif kind == 'SET_ATTITUDE_TARGET':
                sp = offboard_input.from_attitude_message(msg)
            else:
                now = self.px4.t()
                known = self.flight.commander.ready(now)
                home_amsl = self.origin.alt0 - self.flight.home[2] if known else None
                sp = offboard_input.from_global_message(msg, self.origin if known else None, home_amsl)
        except offboard_input.SetpointRejected as err:
            self.counters['setpoints_rejected'] += 1
            if self.counters['setpoints_rejected'] in (1, 10, 100, 1000):
                log.warning('%s rejected (%d setpoints so far): %s', kind, self.counters['setpoints_rejected'], err)
            return
        self.counters['setpoints_accepted'] += 1
        for probe in self.px4.setpoint_probes:
            probe(msg, link)
        self.flight.on_offboard_setpoint(sp, self.px4.t())

    def _on_setup_signing(self, msg, _link):
        """SETUP_SIGNING sets the key (all zeros clears it); with a key in force, only a frame
        signed with it gets this far. The key file is rewritten, as PX4 does."""
        if not self.px4.for_me(msg):
            return
        key = bytes(msg.secret_key)
        if any(key):
            for link in self.links:
                link.enable_signing(key, msg.initial_timestamp, required=True)
            log.info('signing key set by SETUP_SIGNING from system %d', msg.get_srcSystem())
        else:
            for link in self.links:
                link.disable_signing()
            log.info('signing key cleared by SETUP_SIGNING from system %d', msg.get_srcSystem())
        if self.px4.signing_key_file:
            try:
                write_signing_key(self.px4.signing_key_file, key, msg.initial_timestamp)
            except OSError as err:
                log.error('cannot write the signing key file %s: %s', self.px4.signing_key_file, err)

    def _on_timesync(self, msg, link):
        """Answer a request (tc1 0) with the boot clock in ns, the clock of time_boot_ms, addressed to
        the requester, as PX4; answers to our own requests (tc1 set) are taken silently."""
        if msg.tc1 == 0:
            link.send(TimesyncAnswer(int(self.px4.t() * 1e9), msg.ts1, msg.get_srcSystem(), msg.get_srcComponent()))

    def _on_ping(self, msg, link):
        """A PING request (target 0/0) goes back to its sender with the sender as target, as PX4's
        MavlinkReceiver::handle_message_ping; a PING for anyone else is not a request."""
        if msg.target_system == 0 and msg.target_component == 0:
            link.send(self.mav.ping_encode(msg.time_usec, msg.seq, msg.get_srcSystem(), msg.get_srcComponent()))

    def _set_current(self, seq):
        if self.flight.set_mission_current(seq):
            self.px4.broadcast(self.telemetry.build('MISSION_CURRENT', self.px4.status(), self.px4.t()))
