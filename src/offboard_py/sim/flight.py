"""The flight stack of the simulated PX4: commander, navigator, offboard setpoint and vehicle model, stepped together.

`Flight.step(now_s, dt)` is one cycle of PX4's loop: the commander's checks, the setpoint of
the mode flying now (the latest offboard setpoint in OFFBOARD, a ground station's sticks in the manual modes
once MANUAL_CONTROL brought them (sim.manual_control), else the navigator's), the
vehicle model, then the land detector's word back to the commander. Events from the
commander and the navigator are routed here at once (arming starts the motors, a mode
change moves the navigator) and queued in `events` for the autopilot to say on the link.
`status()` is the read-only picture telemetry is built from, with what the controller tracks
and the battery. Positions there are the estimate (vehicle.Estimator: seeded noise and hover
wander, the ground a little below home's z = 0, as PX4 SITL shows them) unless the flight is ideal.
Home is set where the vehicle is at arming, as PX4 does.

Pure: time is passed in; no MAVLink I/O, no clock.
"""

from typing import NamedTuple

from offboard_py import px4_modes
from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import failures
from offboard_py.sim.battery_simulator import BatterySimulator
from offboard_py.sim.commander import READY_S, Commander
from offboard_py.sim.geofence import Geofence
from offboard_py.sim.manual_control import CENTRED, FLOWN_MODES, ManualControl
from offboard_py.sim.navigator import Navigator
from offboard_py.sim.estimator import ESTIMATOR_FLAGS_READY, Estimator, estimator_flags
from offboard_py.sim.vehicle import VehicleModel

NAN3 = (float('nan'),) * 3
HOVER_THRUST = 0.5  # normalised thrust that holds the vehicle (PX4's MPC_THR_HOVER default)
HOME_SET_S = 2.4    # boot s when PX4 SITL first sets home (2.45 and 2.33 s recorded), unless ready sooner


class Status(NamedTuple):
    """What telemetry may know of the flight (PX4's vehicle_status, land detector, local position ...)."""
    nav_mode: str
    user_mode: str
    armed: bool
    failsafe: bool
    system_status: int
    ready: bool           # the estimator is good (home is set)
    prearm_ok: bool       # the arming checks pass (SYS_STATUS's PREARM_CHECK)
    landed_state: int
    position: tuple       # local NED, m
    velocity: tuple       # local NED, m/s
    yaw: float            # rad from north
    yaw_rate: float       # rad/s
    attitude: tuple       # (w, x, y, z) NED/FRD
    specific_force: tuple  # FRD, m/s^2: what an accelerometer reads
    mission_seq: int
    mission_count: int
    position_setpoint: tuple      # local NED, m; NaN where not controlled (all NaN: motors not flying)
    velocity_setpoint: tuple      # local NED, m/s; NaN likewise
    acceleration_setpoint: tuple  # local NED, m/s^2, commanded; NaN likewise
    yaw_setpoint: float           # rad
    yaw_rate_setpoint: float      # rad/s, NaN when yaw is controlled
    thrust: float                 # normalised 0..1 (HOVER_THRUST holds the vehicle)
    battery_remaining: float      # 0..1
    battery_voltage: float        # V
    home: tuple = (0.0, 0.0, 0.0)  # local NED of home, m: where the vehicle was armed (or booted)
    rc: bool = False               # an RC link is simulated (sticks centred)
    rtl: tuple = None              # while AUTO.RTL flies: (its phase, the return altitude as local z)
    body_rates: tuple = (0.0, 0.0, 0.0)  # FRD, rad/s: the filtered gyro (ATTITUDE's rates)
    logging: bool = True           # the logger runs (SYS_STATUS's LOGGING present/enabled bits)
    gyro: tuple = (0.0, 0.0, 0.0)        # FRD, rad/s: the gyro (HIGHRES_IMU)
    home_set_s: float = None       # boot s when home was last set (HOME_POSITION.time_usec); None: not yet
    battery_warning: int = 0       # battery_status_s::WARNING_* (BATTERY_STATUS.charge_state)
    unhealthy_sensors: int = 0     # SYS_STATUS health bits the reported checks clear
    health_published: bool = True  # the commander has published a health report (else SYS_STATUS: none present)
    gps_present: bool = True       # the reported estimator fuses GPS (SYS_STATUS's GPS present bit)
    estimator_flags: int = ESTIMATOR_FLAGS_READY  # ESTIMATOR_STATUS.flags

    @property
    def custom_mode(self):
        return px4_modes.encode(self.nav_mode)

    @property
    def intended_custom_mode(self):
        return px4_modes.encode(self.user_mode)

    @property
    def base_mode(self):
        return px4_modes.base_mode_flags(self.nav_mode, self.armed)

    @property
    def height(self):
        """Height above home, m (relative altitude)."""
        return self.home[2] - self.position[2]


class Flight:
    def __init__(self, params, origin, now_s, ready_delay_s=READY_S, rc=False, ideal=False, seed=None):
        self.params = params
        self.origin = origin
        seed = params['MAV_SYS_ID'] if seed is None else seed
        self.vehicle = VehicleModel(params, estimator=Estimator(seed, ideal=ideal))
        self.commander = Commander(params, now_s, ready_delay_s=ready_delay_s, rc=rc)
        self.navigator = Navigator(params, origin, self.vehicle)
        self.offboard_sp = None
        self.manual_control = ManualControl(params)  # the manual modes' flight tasks (sim.manual_control)
        self.battery = BatterySimulator(params, now_s)
        self.geofence = Geofence(params)
        self.events = []
        # PX4 sets home as its estimator gets a position, before it is ready: 2.45 and 2.33 s after boot
        # in the two real-PX4 recordings (HOME_POSITION.time_usec, reference/conversations/takeoff-*-px4)
        self.home_first_s = min(HOME_SET_S, ready_delay_s)
        self.home_set_s = None  # then, once the estimator is ready and after an arming: when it was set again
        self.ready_seen = ready_delay_s <= self.home_first_s  # ready at boot: no second home
        self._set_home()

    def set_ideal(self, seed=None):
        """Before the flight: an ideal vehicle (no noise, no wander, the ground at home's z = 0)."""
        seed = self.params['MAV_SYS_ID'] if seed is None else seed
        self.vehicle = VehicleModel(self.params, estimator=Estimator(seed, ideal=True))
        self.navigator.vehicle = self.vehicle
        self.navigator.on_mode(self.commander.nav_mode)
        self._set_home()

    def _set_home(self):
        self.home = tuple(self.vehicle.estimate[0])
        self.navigator.home = self.home

    # -- requests (each returns a MAV_RESULT) --------------------------------------------------

    def request_mode(self, mode, now_s):
        return self._routed(self.commander.request_mode(mode, now_s), now_s)

    def request_base_mode(self, base_mode, main_mode, sub_mode, now_s):
        return self._routed(self.commander.request_base_mode(base_mode, main_mode, sub_mode, now_s), now_s)

    def request_arming(self, arm, force, now_s):
        return self._routed(self.commander.request_arming(arm, force, now_s), now_s)

    def takeoff(self, altitude_amsl, home_alt, now_s):
        """NAV_TAKEOFF: AUTO.TAKEOFF to the given AMSL altitude, or MIS_TAKEOFF_ALT."""
        height = self.navigator.takeoff_height(altitude_amsl, home_alt - self.home[2])
        result = self.request_mode('AUTO.TAKEOFF', now_s)
        if result == mavlink.MAV_RESULT_ACCEPTED:
            self.navigator.set_takeoff_height(height)
        return self._routed(result, now_s)

    def reposition(self, target, speed, yaw, now_s):
        """MAV_CMD_DO_REPOSITION: AUTO.LOITER, flying to `target` (local NED) once the mode is
        granted. As PX4's commander, the answer is the mode change's; as its navigator, the target
        is kept only while armed."""
        result = self.request_mode('AUTO.LOITER', now_s)
        if result == mavlink.MAV_RESULT_ACCEPTED:
            self.navigator.set_reposition(target, speed, yaw, self.commander.armed)
        return self._routed(result, now_s)

    def terminate(self, now_s):
        return self._routed(self.commander.terminate(now_s), now_s)

    def return_to_launch(self, now_s):
        return self._routed(self.commander.return_to_launch(now_s), now_s)

    def set_home(self, home, now_s):
        """MAV_CMD_DO_SET_HOME: `home` local NED, or None for where the vehicle is (HomePosition's
        setHomePosition, which needs a position estimate: TEMPORARILY_REJECTED before)."""
        if not self.commander.ready(now_s):
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        if home is None:
            self._set_home()
        else:
            self.home = tuple(home)
            self.navigator.home = self.home
        self.home_set_s = now_s
        return mavlink.MAV_RESULT_ACCEPTED

    def start_mission(self, first_seq, now_s):
        """MAV_CMD_MISSION_START: from item first_seq (0 if out of range) in AUTO.MISSION."""
        if not self.navigator.mission.items:
            return mavlink.MAV_RESULT_DENIED
        if not self.navigator.mission.set_current(first_seq):
            self.navigator.mission.set_current(0)
        return self.request_mode('AUTO.MISSION', now_s)

    def set_mission_current(self, seq):
        return self.navigator.mission.set_current(seq)

    def load_mission(self, items):
        self.navigator.load_mission(items, self.commander.nav_mode == 'AUTO.MISSION')
        self.commander.has_mission = bool(items)
        self._route(None)

    def load_fence(self, items):
        """The FENCE list a ground station uploaded (sim.geofence)."""
        self.geofence.load(items)

    def inject_failure(self, unit, failure_type, instance, now_s):
        """MAV_CMD_INJECT_FAILURE as the modules of PX4 SITL with Gazebo Classic take it (sim.failures):
        True ACCEPTED, False UNSUPPORTED, None when no module takes it (PX4 then sends no COMMAND_ACK)."""
        return failures.inject(self, unit, failure_type, instance, now_s)

    def on_offboard_setpoint(self, sp, now_s):
        self.offboard_sp = sp
        self.commander.on_offboard_setpoint(now_s)
        self.commander.offboard_needs_position = any(value == value for value in sp.position)

    def on_follow_target(self, position, velocity, now_s):
        """FOLLOW_TARGET's target, local NED (m, m/s): what AUTO.FOLLOW_TARGET follows."""
        self.navigator.follow.on_target(position, velocity, now_s)

    def on_gcs_heartbeat(self, now_s):
        self.commander.on_gcs_heartbeat(now_s)

    def on_manual_control(self, now_s, sticks=None):
        """MANUAL_CONTROL: the RC signal, and its sticks (sim.manual_control.ManualControlSetpoint) if given."""
        self.commander.on_manual_control(now_s, sticks)

    def _manual_setpoint(self, now_s):
        """The setpoint of the manual mode flying, from a ground station's sticks (centred, as PX4's Sticks read
        them, once its MANUAL_CONTROL is lost); None where the navigator's is flown: another mode, or no sticks
        ever came (the simulated RC receiver has none)."""
        c = self.commander
        if c.nav_mode not in FLOWN_MODES or c.manual_control.sticks is None:
            self.manual_control.stop()
            return None
        sticks = c.manual_control.sticks if c.manual_control_signal() else CENTRED
        return self.manual_control.setpoint(c.nav_mode, sticks, self.vehicle, now_s)

    # -- the cycle -----------------------------------------------------------------------------

    def step(self, now_s, dt):
        c, v = self.commander, self.vehicle
        c.position_valid = v.estimator.position_valid(now_s, self.params['EKF2_NOAID_TOUT'] / 1e6)
        if not self.ready_seen and c.ready(now_s):
            # PX4 sets home again as EKF2 starts fusing GPS (3.79 and 3.80 s, the first one 2.33-2.45 s)
            self.ready_seen = True
            if not c.armed:
                self._set_home()
                self.home_set_s = now_s
        c.check(now_s)
        self._route(now_s)
        manual_sp = self._manual_setpoint(now_s)
        if c.nav_mode == 'OFFBOARD' and self.offboard_sp is not None:
            sp = self.offboard_sp
        elif manual_sp is not None:
            sp = manual_sp
        else:
            sp = self.navigator.setpoint(c.nav_mode, c.armed, now_s)
            self._route(now_s)
        v.step(dt, sp, now_s)
        self.battery.step(now_s, c.armed)
        c.battery_warning = self.battery.warning
        if self.geofence.due(now_s):
            c.geofence_result = self.geofence.check(now_s, self.origin.to_global(*v.estimate[0]),
                                                    self.origin.to_global(*self.home), c.armed,
                                                    c.nav_mode == 'AUTO.LOITER')
            if self.geofence.holding_since_s == now_s:  # navigator_main.cpp: hold where the breach was seen
                self.navigator.set_reposition(tuple(v.estimate[0]), None, float('nan'), c.armed)
        c.landed, c.maybe_landed = v.landed, v.maybe_landed
        if self.navigator.mission.landed_at_end and c.nav_mode == 'AUTO.MISSION':
            c.mission_landed(now_s)
        c.check_landing(now_s)
        self._route(now_s)

    def _routed(self, result, now_s):
        self._route(now_s)
        return result

    def _route(self, now_s):
        """Act on what the commander and the navigator said, and queue it for the link."""
        c, n = self.commander, self.navigator
        while c.events or n.events:
            source = c.events if c.events else n.events
            event = source.pop(0)
            if isinstance(event, ev.ModeChanged):
                n.on_mode(event.mode)
                if event.mode == 'TERMINATION':  # PX4 sets the actuators to their failsafe: motors off
                    self.vehicle.stop_motors()
            elif isinstance(event, ev.ArmingChanged):
                if event.armed:
                    self._set_home()  # PX4 sets home again at arming
                    self.home_set_s = now_s
                    self.vehicle.start_motors(now_s)
                    n.on_armed(c.nav_mode)
                else:
                    self.vehicle.stop_motors()
            elif isinstance(event, ev.TakeoffComplete):
                c.takeoff_complete()
                continue
            elif isinstance(event, ev.ReturnToLaunch):
                c.return_to_launch(c.now_s if now_s is None else now_s)
                continue
            self.events.append(event)

    def take_events(self):
        events, self.events = self.events, []
        return events

    # -- what telemetry sees -----------------------------------------------------------------

    def landed_state(self):
        c, v = self.commander, self.vehicle
        if v.landed:
            return mavlink.MAV_LANDED_STATE_ON_GROUND
        if self.navigator.taking_off(c.nav_mode):
            return mavlink.MAV_LANDED_STATE_TAKEOFF
        if self.navigator.landing(c.nav_mode):
            return mavlink.MAV_LANDED_STATE_LANDING
        return mavlink.MAV_LANDED_STATE_IN_AIR

    def status(self, now_s):
        c, v, m, b = self.commander, self.vehicle, self.navigator.mission, self.battery
        sp, acc = v.setpoint, v.acceleration_setpoint
        if sp is None:
            position_sp = velocity_sp = acc_sp = NAN3
            yaw_sp, yaw_rate_sp = v.yaw, float('nan')
        else:
            position_sp, velocity_sp, acc_sp = sp.position, v.velocity_setpoint, tuple(acc)
            yaw_sp = sp.yaw if sp.yaw == sp.yaw else v.yaw
            yaw_rate_sp = float('nan') if sp.yaw == sp.yaw else v.yaw_rate
        thrust = v.collective_thrust() if c.armed else 0.0
        position, velocity = v.estimate
        nav = self.navigator
        rtl = (nav.rtl_phase, nav.rtl_down) if c.nav_mode == 'AUTO.RTL' and nav.rtl_down is not None else None
        return Status(c.nav_mode, c.user_mode, c.armed, c.failsafe, c.system_status(now_s), c.ready(now_s),
                      c.prearm_ok(now_s), self.landed_state(), position, velocity, v.yaw,
                      v.yaw_rate, v.attitude(), v.specific_force_body(), m.seq, len(m.items),
                      position_sp, velocity_sp, acc_sp, yaw_sp, yaw_rate_sp, thrust, b.remaining, b.voltage_v,
                      self.home, c.rc, rtl, v.body_rates, c.logging(now_s), v.gyro, self.home_set(now_s),
                      b.warning, c.unhealthy_sensors(), c.health_published(), c.gps_present(),
                      estimator_flags(now_s - c.boot_s, c.ready_delay_s, c.armed))

    def home_set(self, now_s):
        """Boot s when home was last set, or None before PX4 would have set it (home_first_s)."""
        if self.home_set_s is not None:
            return self.home_set_s
        first = self.commander.boot_s + self.home_first_s
        return first if now_s >= first else None
