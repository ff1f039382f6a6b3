"""The simulated PX4 as a process, and a plain pymavlink client of it: test kit for ROS-free tests.

`start_simulated_px4()` starts the simulator (offboard_py.sim, what scripts/sim_px4.py runs) on an
instance whose ports are free, waits a bounded time for its first HEARTBEAT and returns the
process (`SimProcess`: instance, ports, clock, collected output) and a `Client` on its onboard
link. The client is what mavros, MAVSDK or a script would be to the vehicle: a UDP socket
on the instance's bridge port with a pymavlink codec of our dialect (`client.mav`; `client.write` sends raw
bytes), a receive thread that keeps every
message with its arrival time, waits that fail saying what they awaited and what the vehicle
was doing, commands with their ACKs, and a 20 Hz setpoint stream. The pytest fixtures over
this are in offboard_py.testing.pytest_plugin. No ROS here.

Simulated time: every simulator runs at speed K = OFFBOARD_PY_SPEED (1, real time, if unset)
unless its arguments have their own --speed, and its client runs on the same clock
(offboard_py.simtime): arrival stamps, deadlines and sleeps are in simulated seconds, so a
test reads the same at any speed. Wall-clock limits (starting the process, the kernel's
socket buffer) stay in wall seconds.
"""

import os
import select
import signal
import socket
import struct
import sys
import threading
import time
import warnings

from offboard_py import clock_board, px4_modes
from offboard_py.dialect import ARM_DISARM_FORCE_MAGIC, check_pymavlink_version, mavlink
from offboard_py.mavlink_link import SO_TIMESTAMPNS, STAMP_ANCILLARY_BYTES, kernel_stamp_ns
from offboard_py.signing import signing_timestamp_now
from offboard_py.simtime import SimClock, parse_speed, speed_from_env
from offboard_py.testing import ports
from offboard_py.testing.processes import OutputProcess
from offboard_py.testing.mavros_typemasks import POSITION_AND_YAW

check_pymavlink_version(warnings.warn)  # in pytest's warnings summary when pymavlink is not the tested one

# The simulator's command line, wherever offboard_py is installed (devel space, install space, a venv)
SIM_COMMAND = (sys.executable, '-c', 'from offboard_py.sim.main import main; raise SystemExit(main())')
GCS_EXTRA_PORT = 9  # the extra port (offboard_py.testing.ports) a test's ground station binds
START_WALL_S = 10.0  # a simulator's first HEARTBEAT: starting Python and importing take wall time
START_ATTEMPTS = 3   # instances tried when another process takes the chosen one's ports first
# Linux names no constant for these either: the count of datagrams the socket dropped for a full receive
# buffer (uint32, since it opened) ...
SO_RXQ_OVFL = 40
DROPS = struct.Struct('@I')
SO_RCVBUFFORCE = 33  # past net.core.rmem_max, for root
# A test's process may not read for a while on a loaded machine (CI runs tiers side by side), and
# at 2x a vehicle sends some 800 datagrams a second: the default 208 KB buffer holds a few hundred.
RECEIVE_BUFFER_BYTES = 8 << 20
ACCEPTED, TEMPORARILY_REJECTED, DENIED, UNSUPPORTED, FAILED = (
    mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED, mavlink.MAV_RESULT_DENIED,
    mavlink.MAV_RESULT_UNSUPPORTED, mavlink.MAV_RESULT_FAILED)


def speed_in(args):
    """The value of --speed in a simulator's arguments, or None."""
    for i, arg in enumerate(args):
        if arg == '--speed' and i + 1 < len(args):
            return parse_speed(args[i + 1], '--speed')
        if arg.startswith('--speed='):
            return parse_speed(arg.split('=', 1)[1], '--speed')
    return None


def _session_clock(speed):
    """(the clock a simulator at `speed` runs on, the environment to start it with): the governed clock of
    this process's board ($OFFBOARD_PY_CLOCK_BOARD, which the pytest plugin sets for a session) when it runs
    at that speed, else speed x the monotonic clock, the simulator told to use no board."""
    if os.environ.get(clock_board.BOARD_ENV):
        try:
            return SimClock.for_run(speed), None
        except clock_board.BoardError:  # another speed than the session's: a clock of its own
            pass
    return SimClock(speed), dict(os.environ, **{clock_board.BOARD_ENV: ''})


class SimProcess(OutputProcess):
    """The simulated PX4 as instance INSTANCE with ARGS (sim_px4.py's options), run by this Python
    with the caller's environment, at --speed OFFBOARD_PY_SPEED unless ARGS say otherwise.
    `clock` is its simulated clock; its onboard link binds `fcu_port` and sends to `bridge_port`
    (where a client listens: `url`). Its ground-station link sends to the instance's extra port
    GCS_EXTRA_PORT, `gcs_port` (not to 14550, which tests running side by side would share).
    `client` is the Client start_simulated_px4() attached, if any. It writes no ULog unless ARGS give --log-dir."""

    def __init__(self, instance, *args):
        self.instance = instance
        self.system_id = ports.system_id(instance)
        self.fcu_port = ports.fcu_port(instance)
        self.bridge_port = ports.bridge_port(instance)
        self.gcs_port = ports.extra_port(instance, GCS_EXTRA_PORT)
        self.url = 'udpin:127.0.0.1:%d' % self.bridge_port
        self.client = None
        if not any(arg == '--log-dir' or arg.startswith('--log-dir=') for arg in args):
            args += ('--log-dir', '')  # a test's simulator writes no ULog unless it asks for one
        speed = speed_in(args)
        if speed is None:
            speed = speed_from_env(1.0)
            args += ('--speed', '%g' % speed)
        self.clock, env = _session_clock(speed)
        super().__init__(list(SIM_COMMAND) + ['-i', str(instance), '--gcs-remote-port', str(self.gcs_port)]
                         + list(args), env=env)

    def stop(self):
        """Stop it (SIGTERM, then SIGKILL after 5 s) and reap it; its exit code."""
        return super().stop(signal.SIGTERM, timeout_s=5.0)


class Client:
    """A MAVLink ground station / companion on the instance's bridge port, as mavros or MAVSDK would be,
    on the simulator's clock: every time it keeps or waits is in simulated seconds."""

    POLL_S = 0.02            # simulated seconds between two looks at a condition ...
    POLL_MIN_WALL_S = 0.005  # ... but no busier than this, which would starve the receiving thread
    CATCH_UP_WALL_S = 1.0    # at most this long past a deadline, a wait reads what arrived before it

    def __init__(self, instance, clock, system_id=255, component_id=mavlink.MAV_COMP_ID_MISSIONPLANNER, port=None):
        """On the instance's bridge port (the onboard link's remote), or on `port`; `clock` is the
        simulator's (SimProcess.clock)."""
        self.clock = clock
        self.target = ports.system_id(instance)
        port = ports.bridge_port(instance) if port is None else port
        # A socket of our own, bound as mavutil's udpin: would bind it, answering whoever sent to it: the
        # client speaks our MAVLink 2 dialect through a codec of its own, and pymavlink's mavutil (whose
        # dialect= is process-wide) stays as installed.
        self.port = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.port.bind(('127.0.0.1', port))
        self.clients = set()       # who sent to us: where write() sends
        self.port.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
        self.port.setsockopt(socket.SOL_SOCKET, SO_RXQ_OVFL, 1)
        try:
            self.port.setsockopt(socket.SOL_SOCKET, SO_RCVBUFFORCE, RECEIVE_BUFFER_BYTES)
        except PermissionError:  # not root: as much as net.core.rmem_max allows
            self.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER_BYTES)
        self.mav = mavlink.MAVLink(self, srcSystem=system_id, srcComponent=component_id)
        self.mav.robust_parsing = True
        self.lock = threading.Lock()
        self.latest = {}
        self.history = []          # (simulated time, msg) of everything received
        self.by_type = {}          # message type -> [(simulated time, msg)], the history by type
        self.acks = []             # (simulated time, COMMAND_ACK)
        self.datagrams = []        # (simulated time, bytes, messages) of every datagram received
        self.received_s = float('-inf')  # arrival of the newest datagram read
        self.dropped_datagrams = 0  # lost to a full receive buffer: this process did not read in time
        self.last_setpoint_s = None  # simulated time of the last setpoint start_stream sent
        self._stream = None
        self._running = True
        self._rx = threading.Thread(target=self._receive, daemon=True)
        self._rx.start()
        # on a governed clock this client is a participant: the clock waits while this process is off the CPU
        self._participant = (clock_board.ThreadParticipant(clock.board, 'client of %d' % instance)
                             if getattr(clock, 'board', None) is not None else None)

    def _receive(self):
        """Each datagram whole, stamped with the kernel's arrival time: what the vehicle sent when,
        however late this thread gets to it (at speed K a wall millisecond is K simulated ones), and
        its size and message count kept (PX4 frames one message a datagram; pymavlink's recv_match
        would queue the rest of a datagram that held several behind the next one)."""
        sock = self.port
        while self._running:
            if not select.select([sock], [], [], 0.2)[0]:
                continue
            try:
                data, ancdata, _, address = sock.recvmsg(
                    65535, STAMP_ANCILLARY_BYTES + socket.CMSG_SPACE(DROPS.size))
            except (BlockingIOError, ConnectionRefusedError):
                continue
            now = self._arrival_s(ancdata)
            for level, kind, value in ancdata:
                if level == socket.SOL_SOCKET and kind == SO_RXQ_OVFL and len(value) >= DROPS.size:
                    self.dropped_datagrams = DROPS.unpack_from(value)[0]
            self.clients.add(address)  # write() answers whoever sent to us, as mavutil's udpin does
            msgs = [m for m in self.mav.parse_buffer(data) or () if m.get_type() != 'BAD_DATA']
            with self.lock:
                for msg in msgs:
                    self.latest[msg.get_type()] = msg
                    self.history.append((now, msg))
                    self.by_type.setdefault(msg.get_type(), []).append((now, msg))
                    if msg.get_type() == 'COMMAND_ACK':
                        self.acks.append((now, msg))
                self.datagrams.append((now, len(data), len(msgs)))
                self.received_s = now

    def _arrival_s(self, ancdata):
        """The kernel's arrival stamp (realtime) on the simulated clock; now, when there is none."""
        stamp_ns = kernel_stamp_ns(ancdata)
        if stamp_ns is None:
            return self.clock.now()
        return self.clock.at_monotonic(stamp_ns * 1e-9 - (time.time() - time.monotonic()))

    def send(self, msg):
        with self.lock:
            self.mav.send(msg)

    def write(self, data):
        """Raw bytes to whoever sent to us (the codec's file: MAVLink.send writes through this)."""
        for address in list(self.clients):
            try:
                self.port.sendto(data, address)
            except OSError:  # a client that went away
                pass

    def setup_signing(self, key, sign_outgoing=True, link_id=0):
        """Sign what this client sends with `key` (32 bytes), and check what it receives with it."""
        signing = self.mav.signing
        signing.secret_key, signing.link_id = bytes(key), link_id
        signing.timestamp = signing_timestamp_now()
        signing.sign_outgoing = sign_outgoing

    def disable_signing(self):
        self.mav.signing.secret_key, self.mav.signing.sign_outgoing = None, False

    def due(self, sender, sim_s):
        """A periodic sender of this client's process has its next send due at sim_s (None: stopped): on a
        governed clock the clock waits for it (clock_board.ThreadParticipant.due)."""
        if self._participant is not None:
            self._participant.due(sender, sim_s)

    def close(self):
        self.stop_stream()
        if self._participant is not None:
            self._participant.leave()
        self._running = False
        self._rx.join(timeout=2)
        self.port.close()

    # -- waiting -----------------------------------------------------------------------------

    def now(self):
        """The simulator's time, simulated seconds."""
        return self.clock.now()

    def sleep(self, sim_s):
        """Let sim_s simulated seconds pass, then read what the vehicle sent up to their end (for at most
        CATCH_UP_WALL_S more): a count over the pause must not miss what this process has yet to read."""
        end = self.now() + sim_s
        self.clock.sleep(sim_s)
        give_up = time.monotonic() + self.CATCH_UP_WALL_S
        while self.received_s < end and time.monotonic() < give_up:
            time.sleep(self.POLL_MIN_WALL_S)

    def received(self, msg_type):
        """[(simulated time, msg)] of every `msg_type` received so far."""
        with self.lock:
            return list(self.by_type.get(msg_type, ()))

    def wait_for(self, predicate, timeout_s, what):
        """Poll predicate() until true, for timeout_s simulated seconds; fail saying what was awaited
        and what was seen. Past the deadline it goes on until it has read what the vehicle sent up to
        the deadline (for at most CATCH_UP_WALL_S), so that this process lagging behind the vehicle,
        which at speed K is K times as long in simulated seconds, is not taken for the vehicle's delay."""
        poll_s = max(self.POLL_S, self.clock.sim_s(self.POLL_MIN_WALL_S))
        deadline = self.now() + timeout_s
        give_up = deadline + self.clock.sim_s(self.CATCH_UP_WALL_S)
        while True:
            read_past_deadline = self.received_s >= deadline  # before predicate(): it saw all of that
            value = predicate()
            if value:
                return value
            now = self.now()
            if now >= deadline and (read_past_deadline or now >= give_up):
                break
            self.sleep(poll_s)
        raise AssertionError('timed out after %.1f s (simulated, at %gx) waiting for %s; vehicle: %s'
                             % (timeout_s, self.clock.speed, what, self.describe()))

    def describe(self):
        hb, pos = self.latest.get('HEARTBEAT'), self.latest.get('LOCAL_POSITION_NED')
        text = 'no heartbeat'
        if hb:
            armed = hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            text = 'mode %s, %s, status %d' % (px4_modes.mode_string(hb.base_mode, hb.custom_mode),
                                               'armed' if armed else 'disarmed', hb.system_status)
        if pos:
            text += ', NED (%.2f, %.2f, %.2f)' % (pos.x, pos.y, pos.z)
        return text

    def wait_heartbeat(self, timeout_s=10.0):
        return self.wait_for(lambda: self.latest.get('HEARTBEAT'), timeout_s, 'a HEARTBEAT')

    def mode(self):
        hb = self.latest.get('HEARTBEAT')
        return px4_modes.mode_string(hb.base_mode, hb.custom_mode) if hb else None

    def current_mode(self):
        msg = self.latest.get('CURRENT_MODE')
        return px4_modes.decode(msg.custom_mode) if msg else None

    def armed(self):
        hb = self.latest.get('HEARTBEAT')
        return bool(hb and hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def wait_mode(self, mode, timeout_s):
        """Until the HEARTBEAT says `mode`: PX4 sends it at 1 Hz (CURRENT_MODE at 0.5 Hz), neither at once
        on a change, so a mode change is seen up to a second after it happens, as from real PX4."""
        return self.wait_for(lambda: self.mode() == mode, timeout_s, 'mode ' + mode)

    def wait_armed(self, armed, timeout_s):
        return self.wait_for(lambda: self.armed() == armed, timeout_s, 'armed' if armed else 'disarmed')

    def z(self):
        return self.latest['LOCAL_POSITION_NED'].z

    # -- commands ----------------------------------------------------------------------------

    def command(self, command, *params, timeout_s=3.0, target=None, acks=1):
        """COMMAND_LONG; return the result codes of the first `acks` COMMAND_ACKs for it."""
        params = list(params) + [0.0] * (7 - len(params))
        start = len(self.acks)
        self.send(self.mav.command_long_encode(self.target if target is None else target, 1, command, 0, *params))

        def answers():
            found = [a.result for _, a in self.acks[start:] if a.command == command]
            return found if len(found) >= acks else None
        return self.wait_for(answers, timeout_s, 'COMMAND_ACK for command %d' % command)

    def command_int(self, command, frame, params, x, y, z, timeout_s=3.0):
        """COMMAND_INT with param1..4 `params`, x and y (1e-7 deg in global frames) and z; return the
        result of its first COMMAND_ACK."""
        start = len(self.acks)
        self.send(self.mav.command_int_encode(self.target, 1, frame, command, 0, 0, *params, x, y, z))
        return self._first_ack(start, command, timeout_s)

    def read_param(self, name, timeout_s=3.0):
        """PARAM_REQUEST_READ by name; the PARAM_VALUE of that name that answers it (PX4 also sends
        PARAM_VALUEs unasked: sixteen at boot, CAL_BARO0_OFF at 5.4 s, every change)."""
        self.latest.pop('PARAM_VALUE', None)
        self.send(self.mav.param_request_read_encode(self.target, 1, name.encode(), -1))

        def answer():
            value = self.latest.get('PARAM_VALUE')
            return value if value is not None and value.param_id == name else None
        return self.wait_for(answer, timeout_s, 'PARAM_VALUE ' + name)

    def set_mode(self, mode, timeout_s=3.0):
        """SET_MODE message, as mavros sends it; returns the result of the COMMAND_ACK(DO_SET_MODE)."""
        start = len(self.acks)
        self.send(self.mav.set_mode_encode(self.target, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                           px4_modes.encode(mode)))
        return self._first_ack(start, mavlink.MAV_CMD_DO_SET_MODE, timeout_s)

    def _first_ack(self, start, command, timeout_s):
        def first():
            for _, ack in self.acks[start:]:
                if ack.command == command:
                    return (ack.result,)
            return None
        return self.wait_for(first, timeout_s, 'COMMAND_ACK for command %d' % command)[0]

    def arm(self, arm=True, force=False):
        return self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if arm else 0.0,
                            float(ARM_DISARM_FORCE_MAGIC) if force else 0.0)[0]

    # -- setpoint stream -----------------------------------------------------------------------

    def setpoint(self, north, east, down, yaw=0.0, type_mask=POSITION_AND_YAW, frame=mavlink.MAV_FRAME_LOCAL_NED,
                 velocity=(0.0, 0.0, 0.0)):
        return self.mav.set_position_target_local_ned_encode(0, self.target, 1, frame, type_mask, north, east, down,
                                                             *velocity, 0.0, 0.0, 0.0, yaw, 0.0)

    def start_stream(self, north=0.0, east=0.0, down=-2.0, rate_hz=20.0, message=None):
        """Send a position setpoint at rate_hz (simulated) until stop_stream(); `message`, a function
        returning the message to send, streams another kind of setpoint."""
        self.stop_stream()
        stop = threading.Event()

        def run():
            period = 1.0 / rate_hz
            next_s = self.now()
            while not stop.is_set():
                self.send(message() if message else self.setpoint(north, east, down))
                self.last_setpoint_s = self.now()
                next_s += period
                self.due('setpoint stream', next_s)
                stop.wait(self.clock.wall_s(max(0.0, next_s - self.now())))
            self.due('setpoint stream', None)
        thread = threading.Thread(target=run, daemon=True)
        self._stream = (stop, thread)
        thread.start()

    def stop_stream(self):
        if self._stream:
            stop, thread = self._stream
            stop.set()
            thread.join()
            self._stream = None


def start_simulated_px4(*args, connect=True, taken=(), candidates=ports.PYTEST_INSTANCES,
                        start_timeout_s=START_WALL_S):
    """Start the simulated PX4 with ARGS on a free instance from `candidates` (not in `taken`) and
    wait at most start_timeout_s wall seconds for its first HEARTBEAT; return (SimProcess, Client).

    With connect=False the client is closed once the HEARTBEAT has come and None is returned in
    its place, so that the bridge port (SimProcess.url) is free for a connection of the caller's.
    Ports taken by another process between the choice and the bind: the next free instance is
    tried, START_ATTEMPTS in all. Otherwise a simulator that exits or stays silent is stopped and
    AssertionError says why, with its output. The caller stops the process (SimProcess.stop) and
    closes the client.
    """
    taken = set(taken)
    for _ in range(START_ATTEMPTS):
        instance, = ports.free_instances(1, candidates=candidates, taken=taken)
        taken.add(instance)
        sim = SimProcess(instance, *args)
        try:
            client = _await_heartbeat(sim, start_timeout_s)
        except _PortsTaken:
            sim.stop()
            continue
        except BaseException:
            sim.stop()
            raise
        if not connect:
            client.close()
            client = None
        sim.client = client
        return sim, client
    raise AssertionError('the simulated PX4 could not bind its ports on %d instances in a row (%s): another '
                         'process takes them; pass candidates= a range of instances of your own'
                         % (START_ATTEMPTS, ', '.join(map(str, sorted(taken)))))


class _PortsTaken(Exception):
    """The simulator exited because another process bound its ports first."""


def _await_heartbeat(sim, timeout_s):
    """A Client of sim with its first HEARTBEAT received, within timeout_s wall seconds."""
    try:
        client = Client(sim.instance, sim.clock)
    except OSError as err:  # the bridge port went to someone else since free_instances() looked
        raise _PortsTaken() from err
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if client.latest.get('HEARTBEAT') is not None:
            return client
        if sim.proc.poll() is not None:
            break
        time.sleep(0.05)
    client.close()
    if sim.proc.poll() is not None:
        sim.stop()  # collects the rest of its output
        if 'Address already in use' in sim.output:
            raise _PortsTaken()
        raise AssertionError('the simulated PX4 (instance %d) exited with code %s before its first HEARTBEAT; '
                             'command: %s\nits output:\n%s' % (sim.instance, sim.proc.returncode,
                                                               ' '.join(sim.args), sim.output[-3000:]))
    raise AssertionError('no HEARTBEAT from the simulated PX4 (instance %d) on UDP port %d within %.0f s (wall); '
                         'command: %s\nits output:\n%s' % (sim.instance, sim.bridge_port, timeout_s,
                                                           ' '.join(sim.args), sim.output[-3000:]))
