"""MAVLink I/O of the simulated PX4: receive handlers, command dispatch, the real-time loop.

Two UDP links, as PX4 SITL has: the offboard-API link (local 14580+N, sending to 14540+N)
with PX4's onboard stream set, and the ground-station link (local 18570+N, sending to 14550)
with PX4's normal (GCS) stream set; each sends to whoever talks to it once someone does.
Both links take the same requests through one set of handlers, and a reply goes back on
the link its request came from. Every COMMAND_LONG/COMMAND_INT gets a COMMAND_ACK through a
table {MAV_CMD: handler}; what is addressed to another system is ignored. The flight stack
(sim.flight) steps at `rate_hz` of its clock (real time, or simulated time at `speed` times
real time: offboard_py.simtime); the streams due at each step are built for that step (each
message once, whatever the number of links), and those of the `steps_per_wakeup` steps of one
wake-up go out together (run()), each message in a datagram of its own as PX4 frames them; what
the flight stack says (mode changes, mission progress) goes out on both links at once, its texts
(STATUSTEXT) only on a link where a ground station's HEARTBEAT was heard, as PX4.
"""

import collections
import logging
import math
import struct

from offboard_py import param_codec, px4_modes, sitl_ports
from offboard_py.dialect import (ARM_DISARM_FORCE_MAGIC, FAILURE_TYPE_OK, MAV_CMD_DO_ORBIT, MAV_CMD_INJECT_FAILURE,
                                 mavlink)
from offboard_py.mavlink_link import MavlinkLink
from offboard_py.sim import loop
from offboard_py.simtime import SimClock
from offboard_py.signing import SigningKeyError, read_signing_key, write_signing_key
from offboard_py.sim import events as ev
from offboard_py.sim import mission as missions
from offboard_py.sim import offboard_input
from offboard_py.sim import param_store as sim_params
from offboard_py.sim import telemetry
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import LocalFrame

log = logging.getLogger('offboard_py.sim')

DEFAULT_HOME = (47.397742, 8.545594, 488.0)  # PX4 SITL's default home (Zurich)

# PX4 SITL's ACKs come a few ms after the request and after what it sent for it (PROTOCOL_VERSION,
# AVAILABLE_MODES: about 4 ms later; reference/px4-sitl-measured.md, "Turn 3 recordings", sections 3-4)
ACK_DELAY_S = 0.004
# PARAM_VALUEs per 10 ms loop step while answering PARAM_REQUEST_LIST: PX4 SITL sent its 889 in 0.80 s
# in the recorded conversations (reference/conversations: the pull from 11.0 to 11.8 s), 11 a step
PARAM_LIST_BATCH = 11
ACCEPTED, DENIED, FAILED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_FAILED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED
UNSUPPORTED_MAV_FRAME = mavlink.MAV_RESULT_UNSUPPORTED_MAV_FRAME
# PX4's receiver's sentinels of a command sent in the wrong message: INT32_MAX in COMMAND_LONG's float
# param5/param6 (the floats next to it on either side, as PX4 compares), NaN's float bits in COMMAND_INT's x/y
INT32_MAX_AS_FLOAT = (struct.unpack('<f', struct.pack('<I', 0x4EFFFFFF))[0],
                      struct.unpack('<f', struct.pack('<I', 0x4F000001))[0])
NAN_AS_INT32 = 0x7FF80000
# PX4's MavlinkCommandSender repeats a command it sent until acknowledged: recorded at +1.01, +1.53 and
# +2.04 s after the first, with confirmation 1, 2, 3 (reference/conversations, COMMAND_LONG 1001 and 0)
COMMAND_REPEATS_S = (1.01, 1.53, 2.04)
# GPS_GLOBAL_ORIGIN went out once, 1.0 s after the link's first message, in both real-PX4 recordings
# (reference/conversations/takeoff-mavros-px4 t=1.005, takeoff-bridge-px4 t=1.013: boot 1.44 and 1.33 s,
# PX4's links starting 0.3-0.45 s after its boot); this simulator's links start at its boot
ORIGIN_FIRST_SENT_S = 1.0
# PX4's parameter manager (mavlink_parameters.cpp send_untransmitted) sends on every link, unasked and in
# index order, each parameter changed since boot and not yet saved, a moment after a change: what its start-up
# script set (sensor ids and priorities, the board offsets, the airframe) at boot 1.00 and 1.03 s in the two
# recordings, and the barometer's offset, set by the sensors module's auto-calibration against GPS altitude
# (SENS_BAR_AUTOCAL), at 5.32 and 5.49 s (reference/px4-sitl-boot-params.json). (boot s, names) in time order
BOOT_PARAM_ANNOUNCEMENTS = (
    (1.0, ('CAL_ACC0_ID', 'CAL_ACC1_ID', 'CAL_ACC2_ID', 'CAL_BARO0_ID', 'CAL_BARO0_PRIO', 'CAL_GYRO0_ID',
           'CAL_GYRO1_ID', 'CAL_GYRO2_ID', 'CAL_MAG0_ID', 'CAL_MAG0_PRIO', 'CAL_MAG1_ID', 'CAL_MAG1_PRIO',
           'SENS_BOARD_X_OFF', 'SENS_DPRES_OFF', 'SYS_AUTOCONFIG', 'SYS_AUTOSTART')),
    (5.4, ('CAL_BARO0_OFF',)))
# The barometer's offset PX4 computed at 5 s (Pa): 6.103515625 and -12.20703125 in the two recordings, multiples
# of the pressure's float resolution, so noise; the table's 0 is the default before the calibration
BARO_OFFSET_PA = 6.103515625
# PX4's STATUSTEXT stream (streams/STATUSTEXT.hpp) sends on a link only while a MAV_TYPE_GCS HEARTBEAT was
# heard on it within telemetry_status HEARTBEAT_TIMEOUT_US (2.5 s), one text each time it runs (20 Hz), from
# the mavlink_log queue (8 deep: older texts are overwritten), dropping texts older than 5 s
GCS_HEARTBEAT_TIMEOUT_S = 2.5
STATUSTEXT_INTERVAL_S = 0.05
STATUSTEXT_QUEUE = 8
STATUSTEXT_STALE_S = 5.0
# What REQUEST_MESSAGE's older, dedicated commands ask for
REQUESTED_BY_COMMAND = {mavlink.MAV_CMD_GET_HOME_POSITION: mavlink.MAVLINK_MSG_ID_HOME_POSITION,
                        mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                        mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION: mavlink.MAVLINK_MSG_ID_PROTOCOL_VERSION}


def command_position(msg):
    """(param5, param6, param7) as PX4's receiver puts a COMMAND_LONG or COMMAND_INT into its vehicle
    command: COMMAND_INT's x and y in 1e-7 deg, both INT32_MAX meaning "not given" (NaN), z as param7."""
    if msg.get_type() != 'COMMAND_INT':
        return msg.param5, msg.param6, msg.param7
    if msg.x == msg.y == 0x7FFFFFFF:
        return math.nan, math.nan, msg.z
    return msg.x / 1e7, msg.y / 1e7, msg.z


def c_int_round(value):
    """(int)(value + 0.5f) as PX4's receiver reads a message id from a float parameter; None where C
    leaves it undefined (NaN, infinities, out of int's range)."""
    if not math.isfinite(value) or abs(value) >= 2.0 ** 31:
        return None
    return int(value + 0.5)  # Python's int() truncates towards zero, as the C cast


def lroundf_int8(value, bits=8):
    """static_cast<int8_t>(lroundf(value)) as PX4 SITL computes it on x86-64 (`bits` 32: the int cast):
    halves round away from zero; NaN, infinities and values past a long give LONG_MIN, whose low bits
    are 0; the cast keeps the low `bits`, signed."""
    if not math.isfinite(value) or abs(value) >= 2.0 ** 63:
        return 0
    n = int(math.floor(abs(value) + 0.5)) * (1 if value >= 0 else -1)
    half = 1 << (bits - 1)
    return (n + half) % (1 << bits) - half

# Commands mavlink_receiver.cpp answers itself or passes on before its own-id check
# (handle_message_command_both): these are taken even from a sender with the autopilot's ids
RECEIVER_COMMANDS = frozenset((
    mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION,
    mavlink.MAV_CMD_GET_HOME_POSITION, mavlink.MAV_CMD_REQUEST_FLIGHT_INFORMATION,
    mavlink.MAV_CMD_REQUEST_STORAGE_INFORMATION, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
    mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, mavlink.MAV_CMD_REQUEST_MESSAGE, MAV_CMD_INJECT_FAILURE,
    mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE))


class SimulatedPx4:
    def __init__(self, instance=0, home=DEFAULT_HOME, bind_host='127.0.0.1', local_port=None, remote_port=None,
                 param_overrides=(), ready_delay_s=5.0, rc=False, rate_hz=100.0, steps_per_wakeup=2, clock=None,
                 signing_key_file=None, allowed_systems=(), gcs=True, gcs_port=None, gcs_remote_port=None,
                 pack_datagrams=False):
        # Every timer, rate and time_boot_ms runs on this clock: speed x real time
        self.clock = SimClock(1.0) if clock is None else clock
        clock = self.clock
        self.system_id = sitl_ports.system_id(instance)
        self.rate_hz = rate_hz
        self.steps_per_wakeup = steps_per_wakeup
        now = clock()
        self.boot_s = now
        self.params = sim_params.ParamStore(system_id=self.system_id)
        for text in param_overrides:
            self.params.parse_override(text)
        self.frame = LocalFrame(*home)
        self.flight = Flight(self.params, self.frame, self.t(now), ready_delay_s=ready_delay_s, rc=rc)
        local_port = sitl_ports.fcu_port(instance) if local_port is None else local_port
        remote_port = sitl_ports.bridge_port(instance) if remote_port is None else remote_port
        # Both links keep the first sender they hear from, as PX4's UDP links do (mavlink_link._lock_partner)
        self.link = MavlinkLink((bind_host, local_port), (bind_host, remote_port), self.system_id, 1,
                                name='onboard', lock_remote=True, clock=clock, pack_datagrams=pack_datagrams)
        # what the simulator sends: built by pymavlink's codec, packed and numbered by the link
        self.mav = self.link.mav
        self.links = [self.link]
        self.gcs_link = None
        if gcs:
            gcs_port = sitl_ports.gcs_port(instance) if gcs_port is None else gcs_port
            gcs_remote_port = sitl_ports.GCS_REMOTE_PORT if gcs_remote_port is None else gcs_remote_port
            try:
                self.gcs_link = MavlinkLink((bind_host, gcs_port), (bind_host, gcs_remote_port), self.system_id, 1,
                                            name='GCS', lock_remote=True, clock=clock,
                                            pack_datagrams=pack_datagrams)
            except OSError:
                self.link.close()
                raise
            self.links.append(self.gcs_link)
        self.reply_link = self.link  # the link of the request being handled: answers go back on it
        self.param_lists = {}  # link -> names of a PARAM_REQUEST_LIST answer still to send
        self.transfer = missions.MissionTransfer(self.mav, self.system_id, lambda: self.reply_link,
                                                 lambda text: self._text(mavlink.MAV_SEVERITY_CRITICAL, text),
                                                 self._on_mission_changed)
        self.streams = {self.link: telemetry.Streams(self.t(now), telemetry.ONBOARD_RATES_HZ)}
        if self.gcs_link:
            self.streams[self.gcs_link] = telemetry.Streams(self.t(now), telemetry.GCS_RATES_HZ)
        for streams in self.streams.values():  # HOME_POSITION as soon as home is set, then at its rate
            streams.next_s['HOME_POSITION'] = self.t(now) + self.flight.home_first_s
        self.telemetry = telemetry.TelemetryBuilder(self.mav, self.frame, self.params)
        self.link_counters = {link: telemetry.LinkCounters(link.stats, self.t(now)) for link in self.links}
        for link, counters in self.link_counters.items():
            link.on_frames(counters.on_frame)  # LINK_NODE_STATUS.messages_lost, counted as PX4 counts it
        self.deferred = []  # (clock time due, link, message): answers that PX4 sends a few ms later
        self.gcs_heard = {link: None for link in self.links}  # boot time of the link's last GCS HEARTBEAT
        self.texts = {link: collections.deque(maxlen=STATUSTEXT_QUEUE) for link in self.links}  # (t, sev, text)
        self.text_sent = {link: None for link in self.links}  # boot time of the link's last STATUSTEXT
        self.text_ids = {link: 0 for link in self.links}  # the link's next STATUSTEXT.id: PX4 counts per stream
        self.origin_sent = False  # GPS_GLOBAL_ORIGIN's one message on every link (ORIGIN_FIRST_SENT_S)
        self.boot_announcements = collections.deque(BOOT_PARAM_ANNOUNCEMENTS)  # still to be sent
        self.on_setpoint_accepted = []  # hooks: f(msg) for every accepted setpoint (the benchmark's log)
        self.counters = {'setpoints_accepted': 0, 'setpoints_rejected': 0, 'ignored_other_system': 0,
                         'not_allowed': 0}
        # Signing as PX4 does it with a key on its SD card: outgoing signed, incoming must be.
        self.signing_key_file = signing_key_file
        if signing_key_file:
            try:
                key, timestamp = read_signing_key(signing_key_file)
            except SigningKeyError:
                self.close_links()
                raise
            for link in self.links:
                link.enable_signing(key, timestamp, required=True)
        self.allowed_systems = frozenset(allowed_systems)  # empty: commands from anyone
        self.commands = {
            mavlink.MAV_CMD_DO_SET_MODE: self._cmd_set_mode,
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM: self._cmd_arm_disarm,
            mavlink.MAV_CMD_NAV_TAKEOFF: self._cmd_takeoff,
            mavlink.MAV_CMD_NAV_LAND: lambda msg, now: self.flight.request_mode('AUTO.LAND', now),
            mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda msg, now: self.flight.request_mode('AUTO.RTL', now),
            mavlink.MAV_CMD_MISSION_START: self._cmd_mission_start,
            mavlink.MAV_CMD_DO_REPOSITION: self._cmd_reposition,
            mavlink.MAV_CMD_DO_CHANGE_ALTITUDE: self._cmd_change_altitude,
            mavlink.MAV_CMD_DO_SET_STANDARD_MODE: self._cmd_set_standard_mode,
            MAV_CMD_DO_ORBIT: lambda msg, now: self.flight.request_mode('POSCTL.ORBIT', now),
            mavlink.MAV_CMD_DO_FLIGHTTERMINATION: self._cmd_flight_termination,
            mavlink.MAV_CMD_DO_SET_HOME: self._cmd_set_home,
            mavlink.MAV_CMD_RUN_PREARM_CHECKS: lambda msg, now: ACCEPTED,
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: self._cmd_set_message_interval,
            mavlink.MAV_CMD_GET_MESSAGE_INTERVAL: self._cmd_get_message_interval,
            mavlink.MAV_CMD_REQUEST_MESSAGE: self._cmd_request_message,
            mavlink.MAV_CMD_GET_HOME_POSITION: self._cmd_request_message,
            mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._cmd_request_message,
            mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION: self._cmd_request_message,
            MAV_CMD_INJECT_FAILURE: self._cmd_inject_failure,
        }
        self._register()
        self.running = False

    def t(self, now=None):
        """Seconds since boot: the time base of every pure module."""
        return (self.clock() if now is None else now) - self.boot_s

    def status(self):
        return self.flight.status(self.t())

    # -- receive ---------------------------------------------------------------------------

    def _register(self):
        for link in self.links:
            self._register_on(link)

    def _register_on(self, link):
        def on(msg_type, handler):
            def handle(msg):
                self.reply_link = link
                handler(msg)
            link.on(msg_type, handle)

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
        control('PARAM_SET', self._on_param_set)
        control('SETUP_SIGNING', self._on_setup_signing)
        control('MISSION_COUNT', self._mission(lambda m, t: self.transfer.on_count(m, t)))
        control('MISSION_ITEM_INT', self._mission(lambda m, t: self.transfer.on_item(m, t)))
        control('MISSION_ITEM', self._mission(lambda m, t: self.transfer.on_item(m, t)))
        control('MISSION_CLEAR_ALL', self._mission(lambda m, t: self.transfer.on_clear_all(m, t)))
        control('MISSION_SET_CURRENT', self._mission(lambda m, t: self._set_current(m.seq)))
        on('COMMAND_ACK', self._on_command_ack)
        on('HEARTBEAT', self._on_heartbeat)
        on('PARAM_REQUEST_LIST', self._on_param_request_list)
        on('PARAM_REQUEST_READ', self._on_param_request_read)
        on('MISSION_REQUEST_LIST', self._mission(lambda m, t: self.transfer.on_request_list(m, t)))
        on('MISSION_REQUEST_INT', self._mission(lambda m, t: self.transfer.on_request(m, t)))
        on('MISSION_REQUEST', self._mission(lambda m, t: self.transfer.on_request(m, t)))
        on('MISSION_ACK', self._mission(lambda m, t: self.transfer.on_ack(m, t)))
        on('TIMESYNC', self._on_timesync)
        on('PING', self._on_ping)

    def _control(self, msg_type, handler):
        """`handler` for the allowed systems only."""
        def handle(msg):
            if not self.allowed_systems or msg.get_srcSystem() in self.allowed_systems:
                handler(msg)
                return
            self.counters['not_allowed'] += 1
            n = self.counters['not_allowed']
            if n <= 3 or n % 100 == 0:
                log.warning('ignored %s from system %d: not in the allowed systems %s (%d ignored so far)',
                            msg_type, msg.get_srcSystem(), sorted(self.allowed_systems), n)
        return handle

    def _reply(self, msg):
        """Send an answer on the link its request came from."""
        return self.reply_link.send(msg)

    def _broadcast(self, msg):
        for link in self.links:
            link.send(msg)

    def _for_me(self, msg):
        """PX4 takes messages for its system id or for all (0), on component 1 or all (0)."""
        if msg.target_system in (0, self.system_id) and getattr(msg, 'target_component', 0) in (0, 1):
            return True
        self.counters['ignored_other_system'] += 1
        return False

    def _mission(self, handler):
        """`handler` for what PX4's mission manager takes (sim.mission: its own system id only)."""
        def handle(msg):
            if self.transfer.for_me(msg):
                handler(msg, self.t())
            else:
                self.counters['ignored_other_system'] += 1
        return handle

    def _ack(self, msg, command, result, delay_s=ACK_DELAY_S):
        """COMMAND_ACK on the request's link, `delay_s` (simulated) after now: PX4's commander and
        streams answer on the MAVLink module's next cycles, a few ms after what the request sent."""
        ack = self.mav.command_ack_encode(command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent())
        if delay_s <= 0:
            self._reply(ack)
        else:
            self.deferred.append((self.clock() + delay_s, self.reply_link, ack))

    def _send_deferred(self, now=None):
        """What is due of the deferred answers (their clock times), in their order."""
        if not self.deferred:
            return
        now = self.clock() if now is None else now
        due = [d for d in self.deferred if d[0] <= now]
        if due:
            self.deferred = [d for d in self.deferred if d[0] > now]
            for _, link, msg in due:
                link.send(msg)

    def _send_vehicle_command(self, event):
        """A command of the navigator's, as PX4's COMMAND_LONG stream sends it on every link: to its own
        system, component 0 (MAV_COMP_ID_ALL), after `delay_s`, repeated while unacknowledged."""
        first = self.clock() + event.delay_s
        sends = [(first, 0)]
        if event.repeat:
            sends += [(first + after, i) for i, after in enumerate(COMMAND_REPEATS_S, 1)]
        for due, confirmation in sends:
            msg = self.mav.command_long_encode(self.system_id, mavlink.MAV_COMP_ID_ALL, event.command, confirmation,
                                               *event.params)
            for link in self.links:
                self.deferred.append((due, link, msg))

    def _on_heartbeat(self, msg):
        """A ground station's HEARTBEAT (MAV_TYPE_GCS, any system) lets STATUSTEXT out on its link, as
        PX4's is_gcs_connected(); mavros's MAV_TYPE_ONBOARD_CONTROLLER does not."""
        if msg.type == mavlink.MAV_TYPE_GCS:
            self.gcs_heard[self.reply_link] = self.t()

    def gcs_connected(self, link, now):
        heard = self.gcs_heard[link]
        return heard is not None and now - heard <= GCS_HEARTBEAT_TIMEOUT_S

    def _on_command_ack(self, msg):
        """An answer to a command we sent: PX4's command sender stops repeating it."""
        self.deferred = [d for d in self.deferred
                         if not (d[2].get_type() == 'COMMAND_LONG' and d[2].command == msg.command and d[2].confirmation)]

    def _on_set_mode(self, msg):
        """PX4's receiver turns SET_MODE into a DO_SET_MODE vehicle command for target_system, and the
        commander takes a command for its own system or for all (0), as for COMMAND_LONG."""
        if msg.target_system not in (0, self.system_id):
            self.counters['ignored_other_system'] += 1
            return
        main, sub = px4_modes.split(msg.custom_mode)
        result = self.flight.request_base_mode(msg.base_mode, main, sub, self.t())
        # PX4 answers the SET_MODE message as DO_SET_MODE
        self._ack(msg, mavlink.MAV_CMD_DO_SET_MODE, result)
        self._say_events()

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

    def _on_command(self, msg):
        refused = self._refused_before_dispatch(msg)
        if refused is not None:
            self._ack(msg, msg.command, refused)
            return
        if not self._for_me(msg):
            return
        if msg.command not in RECEIVER_COMMANDS and \
                (msg.get_srcSystem(), msg.get_srcComponent()) == (self.system_id, 1):
            # handle_message_command_both: a command for the commander from our own system and component
            # is ignored, unanswered ("ignoring CMD with same SYS/COMP")
            self.counters['ignored_own_id'] = self.counters.get('ignored_own_id', 0) + 1
            return
        if msg.command == mavlink.MAV_CMD_DO_SET_MODE:
            # PX4's MAVLink module acknowledges at once, then the commander gives its own result:
            # two COMMAND_ACK(176) 1-8 ms apart (reference/px4-sitl-measured.md, section 4)
            self._ack(msg, msg.command, ACCEPTED, delay_s=0.0)
        handler = self.commands.get(msg.command)
        result = handler(msg, self.t()) if handler else UNSUPPORTED
        self._ack(msg, msg.command, result)
        self._say_events()

    # -- commands: handler(msg, now_s) -> MAV_RESULT ------------------------------------------

    def _cmd_set_mode(self, msg, now):
        if not all(map(math.isfinite, (msg.param1, msg.param2, msg.param3))):
            return DENIED
        return self.flight.request_base_mode(int(msg.param1), msg.param2, msg.param3, now)

    def _cmd_arm_disarm(self, msg, now):
        """Commander::handle_command reads param1 and param2 with lroundf (halves away from zero): 0.5
        arms, 0.4 disarms; any other action is 'Unsupported ARM_DISARM param' and the result stays
        UNSUPPORTED. The force magic is lroundf(param2) == 21196."""
        action = lroundf_int8(msg.param1)
        if action not in (0, 1):
            return UNSUPPORTED
        return self.flight.request_arming(action == 1, lroundf_int8(msg.param2, bits=32) == ARM_DISARM_FORCE_MAGIC,
                                          now)

    def _cmd_takeoff(self, msg, now):
        return self.flight.takeoff(command_position(msg)[2], self.frame.alt0, now)

    def _cmd_reposition(self, msg, now):
        """DO_REPOSITION (MAVSDK's goto_location, QGroundControl's "go to location"): param2 must ask
        for the mode change (bit 0) and nothing else, or PX4 answers UNSUPPORTED; latitude and
        longitude (COMMAND_INT: x, y in 1e-7 deg) and the altitude AMSL each NaN for "as now";
        param1 the ground speed (none: MPC_XY_CRUISE), param4 the yaw (NaN: as now)."""
        flags = int(msg.param2) if math.isfinite(msg.param2) else 0
        if not flags & 1 or flags & ~1:
            return UNSUPPORTED
        lat, lon, alt = command_position(msg)
        v = self.flight.vehicle
        north, east, down = v.position
        if math.isfinite(lat) and math.isfinite(lon):
            north, east, _ = self.frame.to_local(lat, lon, self.frame.alt0)
        if math.isfinite(alt):
            down = self.frame.alt0 - alt
        speed = msg.param1 if math.isfinite(msg.param1) and msg.param1 > 0 else None
        return self.flight.reposition((north, east, down), speed, msg.param4, now)

    def _cmd_change_altitude(self, msg, now):
        """DO_CHANGE_ALTITUDE: AUTO.LOITER (Commander::handle_command), and to PX4's navigator a
        DO_REPOSITION with only the altitude: param1 AMSL (NaN: as now), kept only while armed
        (navigator_main.cpp)."""
        north, east, down = self.flight.vehicle.position
        if math.isfinite(msg.param1):
            down = self.frame.alt0 - msg.param1
        return self.flight.reposition((north, east, down), None, math.nan, now)

    def _cmd_set_standard_mode(self, msg, now):
        """DO_SET_STANDARD_MODE: roundf(param1) through mode_util::getNavStateFromStandardMode; a
        standard mode a multicopter has no mode for is FAILED, the mode change's answer otherwise."""
        mode = px4_modes.mode_of_standard(int(round(msg.param1))) if math.isfinite(msg.param1) else None
        if mode is None:
            return FAILED
        return self.flight.request_mode(mode, now)

    def _cmd_flight_termination(self, msg, now):
        """Commander::handle_command: DENIED unless param1 > 0.5 and armed."""
        return self.flight.terminate(now) if msg.param1 > 0.5 else DENIED

    def _cmd_set_home(self, msg, now):
        """Commander::handle_command with COM_HOME_EN: param1 > 0.5 the current position; else the
        latitude, longitude and altitude AMSL given (DENIED unless all are finite). COM_HOME_EN 0: DENIED."""
        if not self.params['COM_HOME_EN']:
            return DENIED
        if msg.param1 > 0.5:
            return self.flight.set_home(None, now)
        lat, lon, alt = command_position(msg)
        if not all(map(math.isfinite, (lat, lon, alt))):
            return DENIED
        return self.flight.set_home(self.frame.to_local(lat, lon, alt), now)

    def _cmd_mission_start(self, msg, now):
        first = int(msg.param1) if math.isfinite(msg.param1) and msg.param1 >= 0 else 0
        return self.flight.start_mission(first, now)

    def _cmd_set_message_interval(self, msg, now):
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
        ok = msg_id is not None and self.streams[self.reply_link].set_interval(msg_id, interval, now)
        return ACCEPTED if ok else FAILED

    def _cmd_get_message_interval(self, msg, now):
        """MESSAGE_INTERVAL for (int)(param1 + 0.5): a stream not running on this link is -1, as PX4
        (MavlinkReceiver::get_message_interval finds no stream of that id)."""
        msg_id = c_int_round(msg.param1)
        interval = -1 if msg_id is None else self.streams[self.reply_link].interval_us(msg_id)
        self._reply(self.mav.message_interval_encode((msg_id or 0) & 0xFFFF, -1 if interval == 0 else interval))
        return ACCEPTED

    def _cmd_request_message(self, msg, now):
        """PX4 answers DENIED for what it cannot send (an unknown id, home before there is one)."""
        msg_id = REQUESTED_BY_COMMAND.get(msg.command, msg.param1)
        if msg_id == mavlink.MAVLINK_MSG_ID_AVAILABLE_MODES:
            return self._available_modes(msg.param2)
        name = telemetry.NAMES_BY_ID.get(int(msg_id)) if math.isfinite(msg_id) else None
        reply = self._build(name, self.reply_link, now) if name else None
        if reply is None:
            return DENIED
        self._reply(reply)
        return ACCEPTED

    def _available_modes(self, which):
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
            self._reply(self.mav.available_modes_encode(len(modes), i, mode.standard_mode, mode.custom_mode,
                                                        mode.properties, mode.mode_name.encode('ascii')))
        return ACCEPTED

    def _build(self, name, link, now):
        """The message `name` as `link` sends it now (None: nothing to say)."""
        if name in telemetry.PER_LINK:
            return self.telemetry.link_node_status(self.link_counters[link], now)
        return self.telemetry.build(name, self.flight.status(now), now)

    def _cmd_inject_failure(self, msg, now):
        if not self.params['SYS_FAILURE_EN']:
            return DENIED  # PX4: failure injection is off unless SYS_FAILURE_EN=1
        self.flight.inject_failure('unit %d' % int(msg.param1), int(msg.param2) != FAILURE_TYPE_OK)
        return ACCEPTED

    # -- setpoints, parameters, signing, timesync, missions ------------------------------------

    def _on_setpoint(self, msg):
        """The three setpoint messages PX4 takes as the offboard signal (sim.offboard_input)."""
        if not self._for_me(msg):
            return
        kind = msg.get_type()
        yaw = self.flight.vehicle.yaw
        try:
            if kind == 'SET_POSITION_TARGET_LOCAL_NED':
                sp = offboard_input.from_message(msg, yaw)
            elif kind == 'SET_ATTITUDE_TARGET':
                sp = offboard_input.from_attitude_message(msg)
            else:
                now = self.t()
                known = self.flight.commander.ready(now)
                home_amsl = self.frame.alt0 - self.flight.home[2] if known else None
                sp = offboard_input.from_global_message(msg, self.frame if known else None, home_amsl)
        except offboard_input.SetpointRejected as err:
            self.counters['setpoints_rejected'] += 1
            if self.counters['setpoints_rejected'] in (1, 10, 100, 1000):
                log.warning('%s rejected (%d setpoints so far): %s', kind, self.counters['setpoints_rejected'], err)
            return
        self.counters['setpoints_accepted'] += 1
        for hook in self.on_setpoint_accepted:
            hook(msg)
        self.flight.on_offboard_setpoint(sp, self.t())

    def _param_value(self, name):
        d = self.params.definition(name)
        return self.mav.param_value_encode(name.encode('ascii'), param_codec.encode(d.type, self.params[name]),
                                           d.type, len(self.params), self.params.index(name))

    def _hash_check(self):
        """The list's first PARAM_VALUE, as PX4 sends it: _HASH_CHECK, UINT32, index 65535, not
        counted in param_count (reference/conversations/takeoff-mavros-px4: _HASH_CHECK at t=11.017,
        seq 221, then index 0), so that a ground station with the list cached can stop at once."""
        return self.mav.param_value_encode(
            sim_params.HASH_CHECK_NAME.encode('ascii'),
            struct.unpack('<f', struct.pack('<I', sim_params.HASH_CHECK_VALUE))[0],  # bytewise, as PX4
            mavlink.MAV_PARAM_TYPE_UINT32, len(self.params), sim_params.HASH_CHECK_INDEX)

    def _on_param_request_list(self, msg):
        """_HASH_CHECK, then the whole table on the requesting link, as PX4, paced by the loop
        (PARAM_LIST_BATCH a step): all at once they overflow a client's socket buffer (a pymavlink
        client on loopback got 785 of 887). 889 take about 0.81 s, as PX4 SITL's 0.80 s. A new
        request while a list is under way on that link starts the table again from index 0 without
        a second _HASH_CHECK, as PX4's MavlinkParametersManager does."""
        if self._for_me(msg):
            restart = self.reply_link in self.param_lists
            self.param_lists[self.reply_link] = collections.deque(
                ([] if restart else [sim_params.HASH_CHECK_NAME]) + self.params.names)

    def _send_param_lists(self, out=None):
        """A cycle's batch of each parameter list under way: into out[link] with the cycle's streams
        (so a wake-up that runs several cycles sends each batch between its cycle's streams, as PX4's
        loop does), or at once when `out` is None."""
        for link, pending in list(self.param_lists.items()):
            names = [pending.popleft() for _ in range(min(PARAM_LIST_BATCH, len(pending)))]
            msgs = [self._hash_check() if name == sim_params.HASH_CHECK_NAME else self._param_value(name)
                    for name in names]
            self._send_on(link, msgs, out)
            if not pending:
                del self.param_lists[link]

    def _on_param_request_read(self, msg):
        """By name (param_index -1), or by index (the same name for the same index); an index
        past the table (888) gets no answer, as on PX4."""
        if not self._for_me(msg):
            return
        if msg.param_index < 0 and msg.param_id == sim_params.HASH_CHECK_NAME:
            self._reply(self._hash_check())
            return
        name = msg.param_id if msg.param_index < 0 else (
            self.params.names[msg.param_index] if msg.param_index < len(self.params) else None)
        if name in self.params:
            self._reply(self._param_value(name))

    def _on_param_set(self, msg):
        """PX4's MAVLink parameter manager: only for its own system id (not 0) and component 1 or 0;
        _HASH_CHECK, an unknown name, a type other than INT32 and REAL32, or not the parameter's own,
        get PARAM_ERROR on the request's link and change nothing; otherwise the value is set and
        PARAM_VALUE tells every link the value in force."""
        if msg.target_system != self.system_id or msg.target_component not in (0, 1):
            self.counters['ignored_other_system'] += 1
            return
        name = msg.param_id
        error = None
        if name == sim_params.HASH_CHECK_NAME:
            error = mavlink.MAV_PARAM_ERROR_READ_ONLY
        elif name not in self.params.names:
            error = mavlink.MAV_PARAM_ERROR_DOES_NOT_EXIST
        elif msg.param_type not in (mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32):
            error = mavlink.MAV_PARAM_ERROR_TYPE_UNSUPPORTED
        elif msg.param_type != self.params.definition(name).type:
            error = mavlink.MAV_PARAM_ERROR_TYPE_MISMATCH
        if error is not None:
            log.warning('PARAM_SET %s (type %d) from system %d refused: PARAM_ERROR %d', name, msg.param_type,
                        msg.get_srcSystem(), error)
            self._reply(self.mav.param_error_encode(msg.get_srcSystem(), msg.get_srcComponent(),
                                                    name.encode('ascii', 'replace'), -1, error))
            return
        d = self.params.definition(name)
        try:
            self.params.set(name, param_codec.decode(d.type, msg.param_value))
        except sim_params.ParamRejected as err:
            self._text(mavlink.MAV_SEVERITY_WARNING, str(err))
        self._broadcast(self._param_value(name))  # the value in force, changed or not; PX4 tells every link

    def _on_setup_signing(self, msg):
        """SETUP_SIGNING sets the key (all zeros clears it); with a key in force, only a frame
        signed with it gets this far. The key file is rewritten, as PX4 does."""
        if not self._for_me(msg):
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
        if self.signing_key_file:
            try:
                write_signing_key(self.signing_key_file, key, msg.initial_timestamp)
            except OSError as err:
                log.error('cannot write the signing key file %s: %s', self.signing_key_file, err)

    def _on_timesync(self, msg):
        """Answer a request (tc1 0) with the boot clock in ns, the clock of time_boot_ms, addressed to
        the requester, as PX4; answers to our own requests (tc1 set) are taken silently."""
        if msg.tc1 == 0:
            self._reply(telemetry.TimesyncAnswer(int(self.t() * 1e9), msg.ts1, msg.get_srcSystem(),
                                                 msg.get_srcComponent()))

    def _on_ping(self, msg):
        """A PING request (target 0/0) goes back to its sender with the sender as target, as PX4's
        MavlinkReceiver::handle_message_ping; a PING for anyone else is not a request."""
        if msg.target_system == 0 and msg.target_component == 0:
            self._reply(self.mav.ping_encode(msg.time_usec, msg.seq, msg.get_srcSystem(), msg.get_srcComponent()))

    def _set_current(self, seq):
        if self.flight.set_mission_current(seq):
            self._broadcast(self.telemetry.build('MISSION_CURRENT', self.status(), self.t()))

    def _on_mission_changed(self, mission_type):
        if mission_type == missions.MISSION_TYPE_MISSION:
            self.flight.load_mission(self.transfer.mission())
            self._say_events()

    # -- send ------------------------------------------------------------------------------

    def _text(self, severity, text):
        """Into every link's queue: each sends it while a ground station is heard on it (_send_texts)."""
        log.info('%s', text)
        now = self.t()
        for queue in self.texts.values():
            queue.append((now, severity, text))

    def _send_texts(self, now, out=None):
        """A link's next fresh text (all its chunks), at most one every STATUSTEXT_INTERVAL_S, while a GCS is
        heard on it; what waits while none is stays queued (STATUSTEXT_QUEUE) and is dropped once
        STATUSTEXT_STALE_S old."""
        for link, queue in self.texts.items():
            if not queue or not self.gcs_connected(link, now):
                continue
            last = self.text_sent[link]
            if last is not None and now - last < STATUSTEXT_INTERVAL_S:
                continue
            while queue:
                said, severity, text = queue.popleft()
                if now - said < STATUSTEXT_STALE_S:
                    msgs = self.telemetry.statustext(severity, text, self.text_ids[link])
                    self.text_ids[link] = (self.text_ids[link] + 1) % 65536  # PX4's uint16_t _id
                    self._send_on(link, msgs, out)
                    self.text_sent[link] = now
                    break

    @staticmethod
    def _send_on(link, msgs, out=None):
        """msgs into out[link], to go out with the wake-up's cycles, or at once when `out` is None."""
        if out is None:
            link.send_many(msgs)
        else:
            out.setdefault(link, []).extend(msgs)

    def _send_everywhere(self, msgs, out=None):
        """What PX4 sends on every link of its own accord, with the cycle (_send_on)."""
        for link in self.links:
            self._send_on(link, msgs, out)

    def _say_events(self):
        """What the flight stack said, on the link."""
        events = self.flight.take_events()
        if not events:
            return
        now = self.t()
        status = self.flight.status(now)
        for event in events:
            if isinstance(event, ev.ModeChanged):
                # logged only: PX4 says a mode change in its next 1 Hz HEARTBEAT and 0.5 Hz CURRENT_MODE, not
                # at once (the recorded conversations: both strictly periodic through every change)
                log.info('mode %s%s, %s', status.nav_mode, ' (failsafe)' if status.failsafe else '',
                         'armed' if status.armed else 'disarmed')
            elif isinstance(event, ev.StatusText) and event.on_link:
                self._text(event.severity, event.text)
            elif isinstance(event, ev.StatusText):
                log.info('%s', event.text)  # PX4 says it as an event only (sim.commander._event)
            elif isinstance(event, ev.MissionCurrent):
                self._broadcast(self.telemetry.build('MISSION_CURRENT', status, now))
            elif isinstance(event, ev.ItemReached):
                self._broadcast(self.mav.mission_item_reached_encode(event.seq))
            elif isinstance(event, ev.VehicleCommand):
                self._send_vehicle_command(event)

    def step(self, dt, slot_s=None, out=None):
        """One cycle of the loop at `slot_s` (the cycle's time on the loop's schedule, seconds
        since boot; default: now): the flight stack's timers, the streams due then and their
        values are that time's, also when one wake-up runs several cycles. The streams and the
        cycle's batch of a parameter list are appended to out[link] to go out with the rest of the
        wake-up's cycles, or sent at once when `out` is None. What the flight stack says (modes,
        mission progress) goes out at once; its texts with the cycle, where a ground station listens."""
        self._send_deferred()
        now = self.t() if slot_s is None else slot_s
        self.flight.step(now, dt)
        self.transfer.tick(now)
        self._say_events()
        if self.param_lists:
            self._send_param_lists(out)
        self._send_texts(now, out)
        if not self.origin_sent and now >= ORIGIN_FIRST_SENT_S:
            self.origin_sent = True
            self._send_everywhere([self.telemetry.build('GPS_GLOBAL_ORIGIN', None, now)], out)
        while self.boot_announcements and now >= self.boot_announcements[0][0]:
            _, names = self.boot_announcements.popleft()
            if 'CAL_BARO0_OFF' in names:
                self.params.set('CAL_BARO0_OFF', BARO_OFFSET_PA)  # the sensors module's calibration
            self._send_everywhere([self._param_value(name) for name in names], out)
        status, built = None, {}
        for link, streams in self.streams.items():
            due = streams.due(now)
            if not due:
                continue
            msgs = [] if out is None else out.setdefault(link, [])
            for name in due:
                if name in telemetry.PER_LINK:
                    msgs.append(self._build(name, link, now))
                    continue
                if name not in built:  # one message per step for all the links that want it
                    if status is None:
                        status = self.flight.status(now)
                    built[name] = self.telemetry.build(name, status, now)
                if built[name] is not None:
                    msgs.append(built[name])
            if out is None and msgs:
                link.send_many(msgs)

    # -- the loop --------------------------------------------------------------------------

    def run(self, duration_s=None):
        """Run on the clock until stop() (or for duration_s of its seconds): the loop of
        offboard_py.sim.loop with this vehicle alone."""
        loop.run_together([self], duration_s)

    def stop(self):
        self.running = False

    def close(self):
        def counts(counter):
            return ', '.join('%s %d' % kv for kv in sorted(counter.items()))
        log.info('link: %s; vehicle: %s', counts(self.link.stats), counts(self.counters))
        if self.gcs_link:
            log.info('GCS link: %s', counts(self.gcs_link.stats))
        self.close_links()

    def close_links(self):
        for link in self.links:
            link.close()
