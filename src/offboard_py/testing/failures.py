"""PX4's failsafes in one call each, for a user's test: a ground station that makes them happen, through MAVLink
only, so the same test drives the simulated PX4 and real PX4 SITL.

`Failures(instance)` is a ground station (MAVLink system 255, component MISSIONPLANNER, HEARTBEAT MAV_TYPE_GCS
at 1 Hz, as QGroundControl) on the vehicle's ground-station link (UDP 18570 + N, PX4 SITL's and the simulated
PX4's), with a joystick (MANUAL_CONTROL, sticks centred, PX4 SITL's COM_RC_IN_MODE 1) when asked for. Each
failure is what a ground station can do to PX4:

  gps_off() / gps_on()         MAV_CMD_INJECT_FAILURE GPS OFF / OK: Gazebo Classic's SimulatorMavlink (and
                               the simulated PX4) stop the GPS; PX4 SITL SIH answers nothing and does nothing
  battery_off() / battery_on() MAV_CMD_INJECT_FAILURE battery OFF / OK (PX4's battery_simulator: empty cells)
  set_battery(percent)         SIM_BAT_MIN_PCT and SIM_BAT_DRAIN by PARAM_SET: the simulated battery drains to
                               `percent` within a second while armed and stays there (BAT_LOW_THR 15 %,
                               BAT_CRIT_THR 7 %, BAT_EMERGEN_THR 5 %); restore_battery() sets them back
  cut_data_link() / restore_data_link()  this ground station's HEARTBEATs stop / resume: after COM_DL_LOSS_T
                               PX4 applies NAV_DLL_ACT (0 in PX4 SITL: nothing; set it first)
  start_joystick() / lose_rc() MANUAL_CONTROL at 20 Hz / stopped: after COM_RC_LOSS_T PX4 applies NAV_RCL_ACT
                               (only where manual control was there at arming)
  upload_fence(items) / fence_circle(radius_m)  a geofence by the mission protocol with mission_type FENCE
                               (as mavros's geofence/push): leaving it, PX4 applies GF_ACTION (2, Hold)
  set_param(name, value)       PARAM_SET, answered by PARAM_VALUE (NAV_DLL_ACT, COM_OBL_RC_ACT, GF_ACTION ...)
  inject(unit, failure_type)   any MAV_CMD_INJECT_FAILURE (PX4 needs SYS_FAILURE_EN 1: else DENIED)

What PX4 says meanwhile is kept: `texts()` (STATUSTEXT: PX4 sends them only to a link with a ground station,
never to mavros), `modes()` and `latest` (HEARTBEAT, SYS_STATUS, BATTERY_STATUS, EXTENDED_SYS_STATE, ...).
Times are the simulated clock's (OFFBOARD_PY_SPEED, as the vehicle's): `now()`, not ROS time. Needs pymavlink,
not ROS. Example:
examples/my_offboard_check/test/test_failsafe.py and docs/failsafes.md.
"""

import threading

from offboard_py import param_codec, px4_modes, sitl_ports
from offboard_py.dialect import FAILURE_TYPE_OFF, FAILURE_TYPE_OK, MAV_CMD_INJECT_FAILURE, mavlink
from offboard_py.simtime import SimClock, speed_from_env
from offboard_py.testing import ports
from offboard_py.testing.sim_client import Client

GCS_LOCAL_PORT_K = 9          # the ground station binds the instance's extra port 9 (testing.ports)
HEARTBEAT_PERIOD_S = 1.0      # QGroundControl's
JOYSTICK_PERIOD_S = 0.05      # MANUAL_CONTROL at 20 Hz (COM_RC_LOSS_T 0.5 s)
STICK_CENTRE, THROTTLE_CENTRE = 0, 500  # MANUAL_CONTROL x/y/r at 0, z at the middle (a hover)
SIM_BAT_FAST_DRAIN_S = 1.0    # SIM_BAT_DRAIN while a set_battery() percentage holds
ANSWER_S = 3.0                # what a command, a parameter or a fence upload may take


class Failures:
    """A ground station of `instance` that causes PX4's failsafes (module docstring). `gcs_port`: the vehicle's
    ground-station port (default 18570 + instance); `local_port`: where this one listens (default the
    instance's extra port 9); `speed`: the simulated clock's (default OFFBOARD_PY_SPEED)."""

    def __init__(self, instance, gcs_port=None, local_port=None, speed=None, system_id=255, heartbeat=True):
        self.clock = SimClock.for_run(speed_from_env(1.0) if speed is None else speed, strict=False)
        local_port = ports.extra_port(instance, GCS_LOCAL_PORT_K) if local_port is None else local_port
        self.client = Client(instance, self.clock, system_id=system_id, port=local_port)
        vehicle = ('127.0.0.1', sitl_ports.gcs_port(instance) if gcs_port is None else gcs_port)
        self.client.clients.add(vehicle)  # a ground station speaks first: PX4 answers whoever talks to it
        self.target = self.client.target
        self.latest = self.client.latest
        self._saved_params = {}
        self._heartbeat = threading.Event()
        self._joystick = threading.Event()
        self._closed = threading.Event()
        if heartbeat:
            self._heartbeat.set()
        senders = [('heartbeat', HEARTBEAT_PERIOD_S, self._heartbeat, self._send_heartbeat),
                   ('joystick', JOYSTICK_PERIOD_S, self._joystick, self._send_manual_control)]
        self._threads = [threading.Thread(target=self._every, args=sender, daemon=True) for sender in senders]
        for thread in self._threads:
            thread.start()

    def _every(self, sender, period_s, enabled, send):
        """send() every period_s while enabled; the governed clock waits for the next one (Client.due)."""
        while not self._closed.is_set():
            if enabled.is_set():
                send()
                self.client.due(sender, self.clock.now() + period_s)
            else:
                self.client.due(sender, None)
            self._closed.wait(self.clock.wall_s(period_s))
        self.client.due(sender, None)

    def _send_heartbeat(self):
        self.client.send(self.client.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID,
                                                          0, 0, mavlink.MAV_STATE_ACTIVE))

    def _send_manual_control(self):
        self.client.send(self.client.mav.manual_control_encode(self.target, STICK_CENTRE, STICK_CENTRE,
                                                               THROTTLE_CENTRE, STICK_CENTRE, 0))

    def close(self):
        self._closed.set()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self.client.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- what PX4 says ----------------------------------------------------------------------------

    def connected(self, timeout_s=10.0):
        """Wait for the vehicle's HEARTBEAT on this link; AssertionError after timeout_s."""
        return self.client.wait_heartbeat(timeout_s)

    def now(self):
        """This ground station's clock (s), which the times of texts() and modes() and their `since` are on: the
        simulated clock (speed x monotonic), not ROS time (epoch seconds in real time)."""
        return self.clock.now()

    def texts(self, since=None):
        """[(time, severity, text)] of the STATUSTEXTs received (after `since`, a time of now()), as a ground station
        shows them: PX4 ends a line it also sends as an event with a tab ("Low battery\\t"), left out here."""
        return [(t, m.severity, m.text[:-1] if m.text.endswith('\t') else m.text)
                for t, m in self.client.received('STATUSTEXT') if since is None or t >= since]

    def wait_text(self, text, timeout_s, since=None):
        """The time of the first STATUSTEXT `text` (after `since`); AssertionError saying what came after timeout_s."""
        def found():
            return next((t for t, _, said in self.texts(since) if said == text), None)
        try:
            return self.client.wait_for(found, timeout_s, 'STATUSTEXT %r' % text)
        except AssertionError as err:
            raise AssertionError('%s; texts: %s' % (err, [said for _, _, said in self.texts(since)])) from None

    def modes(self, since=None):
        """[(time, mode, armed)] from each HEARTBEAT of the autopilot (after `since`)."""
        armed = mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        return [(t, px4_modes.mode_string(m.base_mode, m.custom_mode), bool(m.base_mode & armed))
                for t, m in self.client.received('HEARTBEAT')
                if m.get_srcComponent() == 1 and (since is None or t >= since)]

    def wait_mode(self, mode, timeout_s):
        return self.client.wait_mode(mode, timeout_s)

    # -- commands and parameters ----------------------------------------------------------------

    def inject(self, unit, failure_type, instance=0, timeout_s=ANSWER_S):
        """MAV_CMD_INJECT_FAILURE; the COMMAND_ACK's result, or None when none came within timeout_s (PX4 SITL
        SIH for a sensor unit: no module of it takes the command)."""
        start = len(self.client.acks)
        self.client.send(self.client.mav.command_long_encode(self.target, 1, MAV_CMD_INJECT_FAILURE, 0, unit,
                                                             failure_type, instance, 0, 0, 0, 0))
        deadline = self.now() + timeout_s
        while self.now() < deadline:
            result = next((a.result for _, a in self.client.acks[start:] if a.command == MAV_CMD_INJECT_FAILURE),
                          None)
            if result is not None:
                return result
            self.clock.sleep(0.05)
        return None

    def set_param(self, name, value, timeout_s=ANSWER_S):
        """PARAM_SET `name` (its type as the vehicle has it); the value the vehicle's PARAM_VALUE echoes."""
        current = self.client.read_param(name, timeout_s)
        if name not in self._saved_params:
            self._saved_params[name] = current
        if current.param_type == mavlink.MAV_PARAM_TYPE_REAL32:
            wire, decode = float(value), (lambda v: v)
        else:
            wire = param_codec.encode(current.param_type, int(value))
            decode = (lambda v: param_codec.decode(current.param_type, v))
        self.client.latest.pop('PARAM_VALUE', None)
        self.client.send(self.client.mav.param_set_encode(self.target, 1, name.encode(), wire, current.param_type))

        def echoed():
            echo = self.client.latest.get('PARAM_VALUE')
            return (decode(echo.param_value),) if echo is not None and echo.param_id == name else None
        return self.client.wait_for(echoed, timeout_s, 'PARAM_VALUE %s after PARAM_SET' % name)[0]

    # -- the failures ----------------------------------------------------------------------------

    def gps_off(self):
        return self.inject(mavlink.FAILURE_UNIT_SENSOR_GPS, FAILURE_TYPE_OFF)

    def gps_on(self):
        return self.inject(mavlink.FAILURE_UNIT_SENSOR_GPS, FAILURE_TYPE_OK)

    def battery_off(self):
        return self.inject(mavlink.FAILURE_UNIT_SYSTEM_BATTERY, FAILURE_TYPE_OFF)

    def battery_on(self):
        return self.inject(mavlink.FAILURE_UNIT_SYSTEM_BATTERY, FAILURE_TYPE_OK)

    def set_battery(self, percent):
        """The simulated battery drains to `percent` (0-100) while armed and stays there: PX4's battery_simulator
        floors its charge at SIM_BAT_MIN_PCT and drains it by 1/SIM_BAT_DRAIN a second. The charge PX4 reports
        follows its voltage through a 1 s filter: it gets there about 5 s later."""
        if not 0 <= percent <= 100:
            raise ValueError('set_battery: percent %r, expected 0..100' % (percent,))
        self.set_param('SIM_BAT_DRAIN', SIM_BAT_FAST_DRAIN_S)
        return self.set_param('SIM_BAT_MIN_PCT', float(percent))

    def restore_battery(self):
        """SIM_BAT_MIN_PCT and SIM_BAT_DRAIN as they were before set_battery()."""
        for name in ('SIM_BAT_MIN_PCT', 'SIM_BAT_DRAIN'):
            if name in self._saved_params:
                self.set_param(name, self._saved_params[name].param_value)

    def cut_data_link(self):
        """This ground station goes silent (no HEARTBEAT): PX4 counts the link lost after COM_DL_LOSS_T."""
        self._heartbeat.clear()

    def restore_data_link(self):
        self._heartbeat.set()

    def start_joystick(self):
        """Manual control from this ground station (MANUAL_CONTROL, sticks centred), as a virtual joystick."""
        self._joystick.set()

    def lose_rc(self):
        """The manual control stops: PX4 counts it lost after COM_RC_LOSS_T."""
        self._joystick.clear()

    def home(self, timeout_s=10.0):
        """(lat, lon, alt AMSL) of the vehicle's HOME_POSITION."""
        msg = self.client.wait_for(lambda: self.latest.get('HOME_POSITION'), timeout_s, 'HOME_POSITION')
        return msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0

    def fence_circle(self, radius_m, center=None, inclusion=True):
        """The FENCE items of one circle of `radius_m` around `center` (lat, lon; default: home)."""
        lat, lon = center if center is not None else self.home()[:2]
        command = (mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION if inclusion
                   else mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION)
        return [(command, float(radius_m), lat, lon)]

    def upload_fence(self, items, timeout_s=ANSWER_S):
        """Upload FENCE items [(MAV_CMD_NAV_FENCE_*, param1, lat, lon)] (param1: a circle's radius, m, or a
        polygon's vertex count) by the mission protocol; the MISSION_ACK's type (0: accepted)."""
        client, fence = self.client, mavlink.MAV_MISSION_TYPE_FENCE
        start = len(client.history)
        client.send(client.mav.mission_count_encode(self.target, 1, len(items), fence))
        sent = set()

        def step():
            for _, msg in client.history[start:]:
                kind = msg.get_type()
                if kind == 'MISSION_ACK' and msg.mission_type == fence:
                    return (msg.type,)
                if kind in ('MISSION_REQUEST_INT', 'MISSION_REQUEST') and msg.mission_type == fence \
                        and msg.seq < len(items) and msg.seq not in sent:
                    sent.add(msg.seq)
                    command, param1, lat, lon = items[msg.seq]
                    client.send(client.mav.mission_item_int_encode(
                        self.target, 1, msg.seq, mavlink.MAV_FRAME_GLOBAL, command, 0, 1, param1, 0, 0, 0,
                        int(round(lat * 1e7)), int(round(lon * 1e7)), 0.0, fence))
            return None
        return client.wait_for(step, timeout_s, 'the fence upload\'s MISSION_ACK')[0]
