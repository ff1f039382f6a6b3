"""The simulated PX4 as a real process, and a plain pymavlink client talking to it over UDP.

No ROS: this is how QGroundControl, MAVSDK or a script would see the vehicle.
Each test starts its own simulator instance (its own system id and ports), on instance
numbers that are free at the time (offboard_py.testing.ports).
"""

import os
import signal
import sys
import threading
import time

import pytest

os.environ.setdefault('MAVLINK20', '1')  # mavutil picks MAVLink 1 unless told; PX4 speaks 2
from pymavlink import mavutil  # noqa: E402

from offboard_py import px4_modes  # noqa: E402
from offboard_py.dialect import ARM_DISARM_FORCE_MAGIC, mavlink  # noqa: E402
from offboard_py.testing import ports  # noqa: E402
from offboard_py.testing.processes import OutputProcess  # noqa: E402
from offboard_py.testing.typemask import POSITION_AND_YAW  # noqa: E402

REPO = os.path.realpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..'))
SIM_SCRIPT = os.path.join(REPO, 'scripts', 'sim_px4.py')
GCS_EXTRA_PORT = 9  # the extra port (offboard_py.testing.ports) a test's ground station binds
ACCEPTED, TEMPORARILY_REJECTED, DENIED, UNSUPPORTED, FAILED = (
    mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED, mavlink.MAV_RESULT_DENIED,
    mavlink.MAV_RESULT_UNSUPPORTED, mavlink.MAV_RESULT_FAILED)


class SimProcess(OutputProcess):
    """scripts/sim_px4.py -i INSTANCE ARGS, run by this Python with the caller's environment.
    Its ground-station link sends to the instance's extra port GCS_EXTRA_PORT (not to 14550,
    which tests running side by side would share)."""

    def __init__(self, instance, *args):
        self.instance = instance
        self.gcs_port = ports.extra_port(instance, GCS_EXTRA_PORT)
        super().__init__([sys.executable, SIM_SCRIPT, '-i', str(instance), '--gcs-remote-port', str(self.gcs_port)]
                         + list(args))

    def stop(self):
        return super().stop(signal.SIGTERM, timeout_s=5.0)


class Client:
    """A MAVLink ground station / companion on the instance's bridge port, as mavros or MAVSDK would be."""

    def __init__(self, instance, system_id=255, component_id=mavlink.MAV_COMP_ID_MISSIONPLANNER, port=None):
        """On the instance's bridge port (the onboard link's remote), or on `port`."""
        self.target = ports.system_id(instance)
        port = ports.bridge_port(instance) if port is None else port
        self.conn = mavutil.mavlink_connection('udpin:127.0.0.1:%d' % port,
                                               dialect='development',
                                               source_system=system_id, source_component=component_id)
        self.mav = self.conn.mav
        self.lock = threading.Lock()
        self.latest = {}
        self.history = []          # (time, msg) of everything received
        self.acks = []             # (time, COMMAND_ACK)
        self._stream = None
        self._running = True
        self._rx = threading.Thread(target=self._receive, daemon=True)
        self._rx.start()

    def _receive(self):
        while self._running:
            msg = self.conn.recv_match(blocking=True, timeout=0.2)
            if msg is None or msg.get_type() == 'BAD_DATA':
                continue
            now = time.monotonic()
            with self.lock:
                self.latest[msg.get_type()] = msg
                self.history.append((now, msg))
                if msg.get_type() == 'COMMAND_ACK':
                    self.acks.append((now, msg))

    def send(self, msg):
        with self.lock:
            self.conn.mav.send(msg)

    def close(self):
        self.stop_stream()
        self._running = False
        self._rx.join(timeout=2)
        self.conn.close()

    # -- waiting -----------------------------------------------------------------------------

    def wait_for(self, predicate, timeout_s, what):
        """Poll predicate() until true; fail saying what was awaited and what was seen."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            value = predicate()
            if value:
                return value
            time.sleep(0.02)
        pytest.fail('timed out after %.1f s waiting for %s; vehicle: %s' % (timeout_s, what, self.describe()))

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
        """CURRENT_MODE is sent on every change, so once one has come it is the freshest word."""
        return self.wait_for(lambda: (self.current_mode() or self.mode()) == mode, timeout_s, 'mode ' + mode)

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

    def start_stream(self, north=0.0, east=0.0, down=-2.0, rate_hz=20.0):
        self.stop_stream()
        stop = threading.Event()

        def run():
            period = 1.0 / rate_hz
            next_s = time.monotonic()
            while not stop.is_set():
                self.send(self.setpoint(north, east, down))
                self.last_setpoint_s = time.monotonic()
                next_s += period
                stop.wait(max(0.0, next_s - time.monotonic()))
        thread = threading.Thread(target=run, daemon=True)
        self._stream = (stop, thread)
        thread.start()

    def stop_stream(self):
        if self._stream:
            stop, thread = self._stream
            stop.set()
            thread.join()
            self._stream = None


@pytest.fixture
def start_sim():
    """start_sim(*args) -> (SimProcess, Client with a heartbeat received), on a free instance."""
    started = []

    def start(*args):
        instance, = ports.free_instances(1, taken=[sim.instance for sim, _ in started])
        sim = SimProcess(instance, *args)
        client = Client(instance)
        started.append((sim, client))
        try:
            client.wait_heartbeat(10.0)
        except BaseException:
            print(sim.output)
            raise
        return sim, client
    yield start
    for sim, client in started:
        client.close()
        sim.stop()
