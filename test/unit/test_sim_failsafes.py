"""The simulated PX4's failsafes, offline, on its flight stack: each failure injected as PX4 SITL takes it, each
reaction as PX4's failsafe framework makes it (src/modules/commander/failsafe/failsafe.cpp and framework.cpp,
PX4 main 02e73e3b6f), and the battery switched off held to the real PX4 SITL recording
(reference/px4-sitl-battery-off.json: px4-sitl-measured.md, "Turn 4 recordings", item 6)."""

import json
import math
import os

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import failsafe as fs
from offboard_py.sim import failsafe_framework as ff
from offboard_py.sim import offboard_input
from offboard_py.sim.battery_simulator import WARNING_CRITICAL, WARNING_EMERGENCY, WARNING_LOW
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.mavlink import mission_manager
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.mavros_typemasks import POSITION_AND_YAW
from offboard_py.testing.reference import px4_figure, px4_param, px4_rc_loss_seen_s

from offboard_flight import OffboardFlight

M = mavlink
REFERENCE = os.path.join(os.path.dirname(__file__), '..', '..', 'reference')
ORIGIN = GeoOrigin(47.397742, 8.545594, 488.0)
NAN = float('nan')
TOLERANCE = 0.25  # of the recorded time
STEP_S = 0.02  # a step of the flight here (OffboardFlight)
# PX4's figures (reference/): the parameters as PX4 SITL has them, and its source's
FAIL_ACT_S = px4_param('COM_FAIL_ACT_T')
OF_LOSS_S = px4_param('COM_OF_LOSS_T')
DL_LOSS_S = px4_param('COM_DL_LOSS_T')
NOAID_S = px4_param('EKF2_NOAID_TOUT') / 1e6
CHECK_S = px4_figure('commander', 'check_period_s')
GCS_TIMEOUT_S = px4_figure('mavlink', 'gcs_heartbeat_timeout_s')
RC_LOSS_SEEN_S = px4_rc_loss_seen_s()
LANDING_BEGINS_S = 8.2  # the battery recording's rows up to AUTO.LAND are held


def load_battery_recording():
    with open(os.path.join(REFERENCE, 'px4-sitl-battery-off.json')) as f:
        return json.load(f)['seconds_from_the_injection']


class Vehicle(OffboardFlight):
    """A flight that records what it says and how its status changes, with the time of each."""

    def __init__(self, rc=False, **params):
        super().__init__(ParamStore(params), ORIGIN, rc=rc)
        self.texts = []     # (t, StatusText)
        self.changes = []   # (t, Status) whenever a watched field changed
        self.joystick = False  # a ground station's MANUAL_CONTROL every step

    def step(self):
        if self.joystick:
            self.flight.on_manual_control(self.t)
        st = super().step()
        self.texts += [(self.t, e) for e in self.flight.take_events() if isinstance(e, ev.StatusText)]
        key = (st.nav_mode, st.user_mode, st.failsafe, st.system_status, st.landed_state, st.armed,
               st.unhealthy_sensors, st.prearm_ok)
        if not self.changes or self._key(self.changes[-1][1]) != key:
            self.changes.append((self.t, st))
        return st

    @staticmethod
    def _key(st):
        return (st.nav_mode, st.user_mode, st.failsafe, st.system_status, st.landed_state, st.armed,
                st.unhealthy_sensors, st.prearm_ok)

    def first(self, condition, since):
        """Seconds from `since` to the first recorded status change that satisfies `condition`."""
        return next((t - since for t, st in self.changes if t >= since and condition(st)), None)

    def said(self, text, since):
        return next((t - since for t, e in self.texts if t >= since and e.text == text), None)

    def offboard_at_2m(self):
        self.setpoint = offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW,
                                                         (0.0, 0.0, -2.0), (0, 0, 0), (0, 0, 0), 0.0, 0.0, 0.0)
        self.run(0.5)
        assert self.flight.request_mode('OFFBOARD', self.t) == M.MAV_RESULT_ACCEPTED
        assert self.flight.request_arming(True, False, self.t) == M.MAV_RESULT_ACCEPTED
        self.until(lambda st: st.position[2] <= -1.9, 15.0, 'the climb to 1.9 m')
        self.run(3.0)

    def takeoff_and_hold(self, hold_s):
        assert self.flight.request_arming(True, False, self.t) == M.MAV_RESULT_ACCEPTED
        assert self.flight.takeoff(NAN, ORIGIN.alt0, self.t) == M.MAV_RESULT_ACCEPTED
        self.until(lambda st: st.nav_mode == 'AUTO.LOITER' and st.user_mode == 'AUTO.LOITER', 20.0, 'AUTO.LOITER')
        self.run(hold_s)

    def inject(self, unit, failure_type, instance=0):
        return self.flight.inject_failure(unit, failure_type, instance, self.t)


def gcs_heartbeats(vehicle, seconds, period_s=1.0):
    """A ground station's HEARTBEAT every period_s while the vehicle flies `seconds`."""
    end = vehicle.t + seconds
    while vehicle.t < end:
        vehicle.flight.on_gcs_heartbeat(vehicle.t)
        vehicle.run(period_s)


# -- the battery switched off, held to the recording ----------------------------------------------

def test_battery_off_in_hold_follows_the_recorded_px4_timeline():
    """BatterySimulator's OFF (empty cells), the battery library's filtered charge crossing BAT_LOW_THR,
    BAT_CRIT_THR and BAT_EMERGEN_THR, COM_LOW_BAT_ACT 3 (Return at critical, Land at emergency), COM_FAIL_ACT_T 5
    (Hold first), the health report's 2 s spacing: each recorded figure within 25 % of PX4's."""
    recorded = load_battery_recording()
    v = Vehicle()
    v.run(0.5)
    v.takeoff_and_hold(5.0)
    t0 = v.t
    assert v.inject(M.FAILURE_UNIT_SYSTEM_BATTERY, M.FAILURE_TYPE_OFF) is True  # COMMAND_ACK 0
    v.until(lambda st: st.nav_mode == 'AUTO.LAND', 15.0, 'the land failsafe')
    v.run(2.0)
    ours = {}
    for row in recorded:
        if row['t'] > LANDING_BEGINS_S:
            continue  # the landing: not held (test_battery_off_lands_disarms_...)
        if row['message'] == 'STATUSTEXT':
            # the recording gives each line as a ground station shows it; on the wire PX4 ends those it also
            # sends as events with a tab (batteryCheck.cpp "Low battery\t", framework.cpp "Failsafe activated\t")
            text = row['text'] + '\t'
            ours[row['t']] = v.said(text, t0)
            severity = next(e.severity for t, e in v.texts if e.text == text and t >= t0)
            assert severity == row['severity'], row
        elif 'health_lost' in row:
            bit = row['health_lost']
            if bit == M.MAV_SYS_STATUS_PREARM_CHECK:
                ours[row['t']] = v.first(lambda st: not st.prearm_ok, t0)
            else:
                ours[row['t']] = v.first(lambda st: st.unhealthy_sensors & bit, t0)
        elif row.get('system_status') == M.MAV_STATE_CRITICAL:
            ours[row['t']] = v.first(lambda st: st.system_status == M.MAV_STATE_CRITICAL
                                     and st.nav_mode == row['mode'], t0)
        elif row.get('landed_state') == M.MAV_LANDED_STATE_LANDING:
            ours[row['t']] = v.first(lambda st: st.landed_state == M.MAV_LANDED_STATE_LANDING, t0)
        elif row.get('mode') == 'AUTO.LAND':
            ours[row['t']] = v.first(lambda st: st.nav_mode == 'AUTO.LAND', t0)
    held = [row for row in recorded if row['t'] in ours]
    assert len(held) == 10, [row['t'] for row in held]
    for row in held:
        t = ours[row['t']]
        assert t is not None, 'never: %s' % row
        assert abs(t - row['t']) <= TOLERANCE * row['t'], '%s at %.2f s, PX4 %.2f s' % (
            row.get('text') or row['what'], t, row['t'])


def test_battery_off_lands_disarms_and_leaves_the_vehicle_unable_to_arm():
    """After the landing: "Landing detected", "Disarmed by landing", back in the user's AUTO.LOITER with
    system_status UNINIT (the emergency battery fails the arming checks). The landing itself is not held
    to the battery recording (6.6 s from ~2.8 m there, against 12.8 s from 2.2 m for a commanded NAV_LAND in
    px4-sitl-measured.md, "AUTO modes", which the land detector follows)."""
    v = Vehicle()
    v.run(0.5)
    v.takeoff_and_hold(5.0)
    t0 = v.t
    v.inject(M.FAILURE_UNIT_SYSTEM_BATTERY, M.FAILURE_TYPE_OFF)
    v.until(lambda st: not st.armed, 40.0, 'the disarm')
    assert v.said('Landing detected\t', t0) < v.said('Disarmed by landing\t', t0)
    st = v.flight.status(v.t)
    assert (st.nav_mode, st.failsafe, st.system_status) == ('AUTO.LOITER', False, M.MAV_STATE_UNINIT)
    assert st.battery_warning == WARNING_EMERGENCY and st.landed_state == M.MAV_LANDED_STATE_ON_GROUND
    assert v.flight.request_arming(True, False, v.t) == M.MAV_RESULT_TEMPORARILY_REJECTED


def test_battery_failure_types_and_instances_as_battery_simulator():
    """BatterySimulator takes OFF and OK for instance 0 (ACCEPTED), other instances UNSUPPORTED, and leaves other
    failure types to others: no answer."""
    v = Vehicle()
    assert v.inject(M.FAILURE_UNIT_SYSTEM_BATTERY, M.FAILURE_TYPE_OFF, 1) is False
    assert v.inject(M.FAILURE_UNIT_SYSTEM_BATTERY, M.FAILURE_TYPE_STUCK) is None
    assert v.inject(M.FAILURE_UNIT_SYSTEM_BATTERY, M.FAILURE_TYPE_OK) is True
    assert v.inject(M.FAILURE_UNIT_SYSTEM_RC_SIGNAL, M.FAILURE_TYPE_OFF) is None, 'no module of PX4 takes it'
    assert v.inject(M.FAILURE_UNIT_SYSTEM_MOTOR, M.FAILURE_TYPE_OFF) is False, 'motors: not modelled'


def test_battery_drained_to_a_percentage_warns_then_returns():
    """SIM_BAT_MIN_PCT holds the simulated charge there (BatterySimulator): 14 % is LOW (BAT_LOW_THR 0.15):
    "Low battery", a warning only; 6 % is CRITICAL: Hold for COM_FAIL_ACT_T, then Return (COM_LOW_BAT_ACT 3)."""
    v = Vehicle()
    v.offboard_at_2m()
    v.flight.params.set('SIM_BAT_DRAIN', 1.0)
    v.flight.params.set('SIM_BAT_MIN_PCT', 14.0)
    t0 = v.t
    v.run(6.0)  # the charge at 14 % within a second, the filtered one 5 s later
    st = v.flight.status(v.t)
    assert st.battery_warning == WARNING_LOW and 0.13 <= st.battery_remaining <= 0.15
    assert (st.nav_mode, st.failsafe) == ('OFFBOARD', False), 'a low battery only warns'
    assert v.said('Low battery\t', t0) is not None
    v.flight.params.set('SIM_BAT_MIN_PCT', 6.0)
    t1 = v.t
    v.until(lambda st: st.failsafe, 5.0, 'the critical-battery failsafe')
    assert v.flight.status(v.t).nav_mode == 'AUTO.LOITER' and v.said(
        'Failsafe activated: entering Hold for 5 seconds\t', t1) is not None
    held = v.until(lambda st: st.nav_mode == 'AUTO.RTL', 8.0, 'the return')
    assert abs(held - FAIL_ACT_S) <= CHECK_S + 2 * STEP_S, 'Hold for COM_FAIL_ACT_T, then Return: %.2f s' % held
    assert v.flight.status(v.t).user_mode == 'OFFBOARD', 'the user\'s mode stays'
    assert v.flight.status(v.t).battery_warning == WARNING_CRITICAL


def test_the_pilot_takes_over_a_battery_failsafe_by_a_mode_change():
    """A mode change during the failsafe is a takeover (getSelectedAction: allowed for Auto actions), as a
    node that keeps asking for OFFBOARD does: the vehicle flies OFFBOARD again, the battery still critical."""
    v = Vehicle()
    v.offboard_at_2m()
    v.flight.params.set('SIM_BAT_DRAIN', 1.0)
    v.flight.params.set('SIM_BAT_MIN_PCT', 6.0)
    v.until(lambda st: st.nav_mode == 'AUTO.RTL', 15.0, 'the return')
    assert v.flight.request_mode('OFFBOARD', v.t) == M.MAV_RESULT_ACCEPTED
    v.run(3.0)
    st = v.flight.status(v.t)
    assert (st.nav_mode, st.failsafe, st.battery_warning) == ('OFFBOARD', False, WARNING_CRITICAL)


# -- the data link ---------------------------------------------------------------------------------

def test_data_link_loss_is_ignored_by_default_and_returns_with_nav_dll_act():
    """NAV_DLL_ACT 0 (PX4 SITL): nothing. NAV_DLL_ACT 2: no GCS HEARTBEAT for COM_DL_LOSS_T (telemetry_status
    keeps one for 2.5 s, looked at every 1.25 s) -> "Connection to ground station lost", Hold for COM_FAIL_ACT_T,
    Return."""
    quiet = Vehicle()
    gcs_heartbeats(quiet, 3.0)
    quiet.offboard_at_2m()
    quiet.run(20.0)
    assert quiet.flight.status(quiet.t).nav_mode == 'OFFBOARD'
    v = Vehicle(NAV_DLL_ACT=2)
    gcs_heartbeats(v, 3.0)
    v.offboard_at_2m()
    gcs_heartbeats(v, 3.0)
    last = v.t - 1.0  # each period begins with its HEARTBEAT: the last was 1 s before now
    v.until(lambda st: st.failsafe, 20.0, 'the data-link failsafe')
    lost_s = v.t - last
    assert DL_LOSS_S + GCS_TIMEOUT_S / 2 <= lost_s <= DL_LOSS_S + GCS_TIMEOUT_S + CHECK_S + 2 * STEP_S, \
        'GCS lost %.2f s after its last HEARTBEAT' % lost_s
    assert v.flight.status(v.t).nav_mode == 'AUTO.LOITER'
    assert v.said('Connection to ground station lost\t', last) is not None
    assert v.said('Failsafe activated: entering Hold for 5 seconds\t', last) is not None
    held = v.until(lambda st: st.nav_mode == 'AUTO.RTL', 8.0, 'the return')
    assert abs(held - FAIL_ACT_S) <= CHECK_S + 2 * STEP_S


def test_without_a_ground_station_nav_dll_act_refuses_arming():
    """rcAndDataLinkCheck: NAV_DLL_ACT > 0 needs a GCS to arm ("No connection to the GCS")."""
    v = Vehicle(NAV_DLL_ACT=2)
    v.run(1.0)
    assert v.flight.request_arming(True, False, v.t) == M.MAV_RESULT_TEMPORARILY_REJECTED
    gcs_heartbeats(v, 2.5)
    assert v.flight.request_arming(True, False, v.t) == M.MAV_RESULT_ACCEPTED


# -- the offboard signal, each COM_OBL_RC_ACT --------------------------------------------------------

@pytest.mark.parametrize('obl_act, with_rc, without_rc', [
    (0, 'POSCTL', 'AUTO.RTL'), (1, 'ALTCTL', 'AUTO.RTL'), (2, 'STABILIZED', 'AUTO.RTL'),
    (3, 'AUTO.RTL', 'AUTO.RTL'), (4, 'AUTO.LAND', 'AUTO.LAND'), (5, 'AUTO.LOITER', 'AUTO.LOITER'),
    (6, 'TERMINATION', 'TERMINATION'), (7, 'disarmed', 'disarmed')])
def test_offboard_loss_for_each_com_obl_rc_act(obl_act, with_rc, without_rc):
    """Failsafe::checkModeFallback: COM_OBL_RC_ACT's mode, its RC modes falling to NAV_RCL_ACT (2: Return)
    without RC; at once (a mode fallback is not delayed), the user's OFFBOARD kept as the intended mode."""
    for rc, expected in ((True, with_rc), (False, without_rc)):
        v = Vehicle(rc=rc, COM_OBL_RC_ACT=obl_act)
        v.offboard_at_2m()
        v.streaming = False
        last = v.flight.commander.offboard_s
        v.until(lambda st: st.nav_mode != 'OFFBOARD' or not st.armed, 3.0, 'the offboard-loss failsafe')
        st = v.flight.status(v.t)
        assert (st.nav_mode if st.armed else 'disarmed') == expected, (obl_act, rc, st.nav_mode)
        assert v.t - last <= OF_LOSS_S + CHECK_S + STEP_S, 'COM_OF_LOSS_T, checked at 10 Hz: %.2f s' % (v.t - last)
        assert st.user_mode == 'OFFBOARD' or not st.armed


# -- RC -------------------------------------------------------------------------------------------

def test_manual_control_loss_only_where_it_was_in_use():
    """A ground station's MANUAL_CONTROL (COM_RC_IN_MODE 1) stopping: after COM_RC_LOSS_T, NAV_RCL_ACT 2 (Return)
    after COM_FAIL_ACT_T in Hold; a vehicle armed without it never has the RC failsafe
    (Failsafe::_manual_control_lost_at_arming) until manual control comes. The simulated RC receiver (--rc)
    never fails."""
    v = Vehicle()
    v.joystick = True
    v.offboard_at_2m()
    v.joystick = False
    lost = v.until(lambda st: st.failsafe, 1.5, 'the RC-loss failsafe')
    # COM_RC_LOSS_T, which PX4's ManualControl sees on its first look after it (every look_period_s without a
    # sample: ManualControl.cpp ScheduleDelayed(200_ms)), so 0.6 s; then the commander's 10 Hz checks
    assert RC_LOSS_SEEN_S - 1e-9 <= lost <= RC_LOSS_SEEN_S + CHECK_S + STEP_S, \
        'COM_RC_LOSS_T, seen at %.1f s, checked at 10 Hz: %.2f s' % (RC_LOSS_SEEN_S, lost)
    assert v.flight.status(v.t).nav_mode == 'AUTO.LOITER'
    held = v.until(lambda st: st.nav_mode == 'AUTO.RTL', 8.0, 'the return')
    assert abs(held - FAIL_ACT_S) <= CHECK_S + 2 * STEP_S
    without = Vehicle()
    without.offboard_at_2m()
    without.run(8.0)
    assert without.flight.status(without.t).nav_mode == 'OFFBOARD', 'no manual control at arming: none to lose'
    without.joystick = True  # manual control that comes in flight counts from then on
    without.run(2.0)
    without.joystick = False
    without.until(lambda st: st.failsafe, 1.5, 'the RC-loss failsafe')


# -- the geofence ---------------------------------------------------------------------------------

def circle_fence(radius_m, inclusion=True):
    command = M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION if inclusion else M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
    return [mission_manager.Item(M.MAV_FRAME_GLOBAL, command, 1, radius_m, 0, 0, 0, ORIGIN.lat0, ORIGIN.lon0, 0.0)]


def test_geofence_breach_holds_where_it_was_seen():
    """GF_ACTION 2 (PX4 SITL): the vehicle leaving an inclusion circle holds (AUTO.LOITER) at once, says
    "Geofence: approaching or outside geofence", and cannot arm outside the fence."""
    v = Vehicle()
    v.flight.load_fence(circle_fence(5.0))
    v.offboard_at_2m()
    t0 = v.t
    v.setpoint = offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW, (12.0, 0.0, -2.0),
                                                  (0, 0, 0), (0, 0, 0), 0.0, 0.0, 0.0)
    v.until(lambda st: st.nav_mode == 'AUTO.LOITER', 10.0, 'the geofence hold')
    crossed = v.flight.vehicle.position[0]
    assert 5.0 <= crossed <= 7.0, 'held %.1f m from home, the fence at 5 m' % crossed
    assert v.said('Geofence: approaching or outside geofence', t0) is not None
    v.run(12.0)  # braking from 5 m/s overshoots (PX4 has GF_PREDICT for that), then back to the breach point
    assert v.flight.status(v.t).nav_mode == 'AUTO.LOITER'
    assert abs(v.flight.vehicle.position[0] - crossed) < 1.5, 'holds %.1f m north, the breach seen at %.1f m' % (
        v.flight.vehicle.position[0], crossed)


def test_geofence_polygon_and_exclusion():
    from offboard_py.sim.geofence import Geofence
    params = ParamStore({})
    square = [mission_manager.Item(M.MAV_FRAME_GLOBAL, M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 1, 4, 0, 0, 0,
                                   lat, lon, 0.0) for lat, lon in ((47.0, 8.0), (47.0, 8.1), (47.1, 8.1), (47.1, 8.0))]
    fence = Geofence(params)
    fence.load(square)
    assert fence.holds(47.05, 8.05) and not fence.holds(47.15, 8.05)
    fence.load(square + [mission_manager.Item(M.MAV_FRAME_GLOBAL, M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 1, 100.0,
                                              0, 0, 0, 47.05, 8.05, 0.0)])
    assert not fence.holds(47.05, 8.05) and fence.holds(47.02, 8.02)


# -- GPS ------------------------------------------------------------------------------------------

def test_gps_off_in_offboard_falls_back_once_ekf2_gives_up():
    """GPS off (SimulatorMavlink stops the GPS): EKF2 dead-reckons for EKF2_NOAID_TOUT (5 s), then its position is
    invalid; position setpoints are then no offboard signal (OffboardChecks). COM_OBL_RC_ACT 0 stands for
    Position, which cannot run without a position: checkModeFallback takes Altitude (whether RC is there or
    not, as PX4's does). Modes that need a position are refused."""
    v = Vehicle()
    v.offboard_at_2m()
    assert v.inject(M.FAILURE_UNIT_SENSOR_GPS, M.FAILURE_TYPE_OFF) is True
    took = v.until(lambda st: st.nav_mode != 'OFFBOARD', 8.0, 'the position-loss failsafe')
    assert NOAID_S <= took <= NOAID_S + 2 * CHECK_S, 'EKF2_NOAID_TOUT, then the 10 Hz checks: %.2f s' % took
    st = v.flight.status(v.t)
    assert (st.nav_mode, st.user_mode, st.failsafe) == ('ALTCTL', 'OFFBOARD', True)
    assert v.flight.request_mode('AUTO.LOITER', v.t) == M.MAV_RESULT_TEMPORARILY_REJECTED, 'Hold needs a position'
    assert v.inject(M.FAILURE_UNIT_SENSOR_GPS, M.FAILURE_TYPE_OK) is True
    v.until(lambda st: st.nav_mode == 'OFFBOARD', 12.0, 'OFFBOARD back once EKF2 fuses the GPS again')


def test_gps_off_in_hold_ends_in_descend_shown_as_land():
    """In AUTO.LOITER the fallback is Return, which needs a position too, then Land (the same), then Descend:
    AUTO.LAND on MAVLink (px4_custom_mode.h)."""
    v = Vehicle()
    v.run(0.5)
    v.takeoff_and_hold(2.0)
    v.inject(M.FAILURE_UNIT_SENSOR_GPS, M.FAILURE_TYPE_OFF)
    v.until(lambda st: st.nav_mode == 'AUTO.LAND', 6.0, 'Descend')
    v.until(lambda st: not st.armed, 30.0, 'the landing')


def test_gps_off_with_rc_in_position_mode_falls_back_to_altitude():
    v = Vehicle(rc=True)
    v.offboard_at_2m()
    assert v.flight.request_mode('POSCTL', v.t) == M.MAV_RESULT_ACCEPTED
    v.inject(M.FAILURE_UNIT_SENSOR_GPS, M.FAILURE_TYPE_OFF)
    v.until(lambda st: st.nav_mode == 'ALTCTL', 6.0, 'ALTCTL')
    assert v.flight.status(v.t).user_mode == 'POSCTL'


# -- the framework, alone -------------------------------------------------------------------------

def test_framework_delays_auto_actions_and_not_fallbacks():
    params = ParamStore({'NAV_DLL_ACT': 3})
    state = fs.Failsafe(params)
    flags = ff.Flags()
    state.update(0.0, True, 'OFFBOARD', False, flags)
    flags.gcs_connection_lost = True
    state.update(0.1, True, 'OFFBOARD', False, flags)
    assert state.selected == ff.Action.HOLD
    state.update(5.2, True, 'OFFBOARD', False, flags)
    assert state.selected == ff.Action.LAND
    assert [text for _, text, on_link in state.notices if on_link] == [
        'Failsafe activated: entering Hold for 5 seconds\t', 'Failsafe activated\t']
    other = fs.Failsafe(params)
    flags = ff.Flags(manual_control_signal_lost=True)  # no RC at arming: no RC failsafe
    other.update(0.0, True, 'OFFBOARD', False, flags)
    flags.offboard_control_signal_lost = True
    other.update(0.1, True, 'OFFBOARD', False, flags)
    assert other.selected == ff.Action.RTL, 'a mode fallback is not delayed'
    assert ff.mode_from_action(ff.Action.HOLD, 'OFFBOARD') == 'AUTO.LOITER'
    assert math.isclose(params['COM_FAIL_ACT_T'], FAIL_ACT_S)


# -- the offboard signal back after its failsafe ----------------------------------------------------

def test_offboard_setpoints_back_fly_offboard_again_as_px4_does():
    """The offboard-loss failsafe is a mode fallback (failsafe.cpp checkModeFallback, cleared when its condition
    clears, framework.cpp): with the setpoints back and OFFBOARD still the user's mode, the vehicle flies OFFBOARD
    again by itself. Held to two runs on real PX4 SITL SIH (reference/px4-sitl-offboard-regain.json): the failsafe
    mode, then OFFBOARD again within one HEARTBEAT period (1 s) of the setpoints' return."""
    with open(os.path.join(REFERENCE, 'px4-sitl-offboard-regain.json')) as f:
        recorded = json.load(f)
    resumed_s = recorded['setpoints_resumed_s']
    for run in recorded['runs']:
        assert [mode for _, mode in run['modes']] == ['OFFBOARD', 'AUTO.RTL', 'OFFBOARD']
        assert 0.0 < run['modes'][-1][0] - resumed_s <= 1.0
    v = Vehicle()  # no RC, as PX4 SITL: COM_OBL_RC_ACT 0 falls to NAV_RCL_ACT (Return)
    v.offboard_at_2m()
    setpoint, v.setpoint = v.setpoint, None
    stopped = v.t
    v.run(resumed_s)
    assert v.flight.status(v.t).nav_mode == 'AUTO.RTL'
    v.setpoint = setpoint
    back = v.t
    v.until(lambda st: st.nav_mode == 'OFFBOARD', 1.0, 'OFFBOARD again with the setpoints back')
    assert v.t - back <= 0.2, 'OFFBOARD again %.2f s after the setpoints came back' % (v.t - back)
    modes = []
    for t, st in v.changes:
        if t >= stopped and (not modes or modes[-1] != st.nav_mode):
            modes.append(st.nav_mode)
    assert modes == [mode for _, mode in recorded['runs'][0]['modes']], modes
