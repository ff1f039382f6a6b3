"""The flight profiles of reference/px4-sitl-measured.md, flown offline against the simulator's
flight stack (sim.flight.Flight) on a simulated clock, faster than real time, and the figures
measured from them the way they were measured on PX4 SITL.

Each profile returns (figures, trace): figures a dict name -> value (s, m, m/s), trace a list of
(t, phase, mode, armed, landed_state, x, y, z, vx, vy, vz) rows in local NED as telemetry reports them.
"""

import math

from offboard_py.dialect import mavlink
from offboard_py.sim import events as ev
from offboard_py.sim import offboard_input
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.mavlink.mission_manager import Item
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.mavros_typemasks import POSITION_AND_YAW
from offboard_py.testing.measured_tables import MISSION_BOX

M = mavlink
NAN = float('nan')
DT = 0.01                 # the simulator's default rate, 100 Hz
SETPOINT_PERIOD_S = 0.05  # the companion's 20 Hz
HOME = (47.397742, 8.545594, 488.0)


def position_setpoint(north, east, down):
    return offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW, (north, east, down),
                                            (0, 0, 0), (0, 0, 0), 0.0, 0.0, 0.0)


class Run:
    """One simulated flight: a Flight, its clock, and the trace telemetry would show."""

    def __init__(self, ideal=False, seed=None, params=None):
        self.params = ParamStore(dict(params or {}))
        self.origin = GeoOrigin(*HOME)
        self.flight = Flight(self.params, self.origin, 0.0, ready_delay_s=0.0, ideal=ideal, seed=seed)
        self.t = 0.0
        self.phase = 'wait'
        self.setpoint = None
        self._next_setpoint_s = 0.0
        self.trace = []
        self.events = []

    def status(self):
        return self.flight.status(self.t)

    def step(self):
        if self.setpoint is not None and self.t >= self._next_setpoint_s - 1e-9:
            self.flight.on_offboard_setpoint(self.setpoint, self.t)
            self._next_setpoint_s = self.t + SETPOINT_PERIOD_S
        self.t += DT
        self.flight.step(self.t, DT)
        self.events.extend((self.t, e) for e in self.flight.take_events())
        st = self.status()
        self.trace.append((self.t, self.phase, st.nav_mode, st.armed, st.landed_state) + tuple(st.position)
                          + tuple(st.velocity))
        return st

    def run(self, seconds):
        for _ in range(int(round(seconds / DT))):
            self.step()

    def until(self, condition, timeout_s):
        """Step until condition(status) holds; the time it took, or None on timeout."""
        start = self.t
        while self.t - start < timeout_s:
            if condition(self.step()):
                return self.t - start
        return None


def offboard_profile(**kwargs):
    """On the ground and ready; setpoint (0,0,-2); OFFBOARD; arm; 12 s; (0,0,-20); then (100,0,-20);
    then setpoints stop (COM_OF_LOSS_T, no RC: Return)."""
    r = Run(**kwargs)
    f = r.flight
    r.run(1.0)
    r.phase = 'takeoff'
    r.setpoint = position_setpoint(0.0, 0.0, -2.0)
    r.run(0.5)
    f.request_mode('OFFBOARD', r.t)
    r.run(0.5)
    assert f.request_arming(True, False, r.t) == M.MAV_RESULT_ACCEPTED
    figures = {}
    figures['arm_to_1.9m_s'] = r.until(lambda st: st.position[2] <= -1.9, 20.0)
    r.run(12.0 - figures['arm_to_1.9m_s'])
    figures['takeoff_overshoot_m'] = max(-z for z in (row[7] for row in r.trace if row[1] == 'takeoff')) - 2.0
    r.phase = 'climb'
    r.setpoint = position_setpoint(0.0, 0.0, -20.0)
    figures['climb_2_to_19.5m_s'] = r.until(lambda st: st.position[2] <= -19.5, 30.0)
    r.run(10.0 - figures['climb_2_to_19.5m_s'])
    r.phase = 'leg'
    r.setpoint = position_setpoint(100.0, 0.0, -20.0)
    leg_start = len(r.trace)
    figures['leg_100m_to_1m_s'] = r.until(lambda st: math.hypot(st.position[0] - 100.0, st.position[1]) <= 1.0, 40.0)
    r.run(15.0 - figures['leg_100m_to_1m_s'])
    figures['leg_peak_speed_mps'] = max(math.hypot(row[8], row[9]) for row in r.trace[leg_start:])
    r.phase = 'loss'
    r.setpoint = None
    loss_start = len(r.trace)
    figures['loss_to_landed_s'] = r.until(lambda st: st.landed_state == M.MAV_LANDED_STATE_ON_GROUND, 200.0)
    rows = r.trace[loss_start:]
    figures['mode_after_loss'] = next(row[2] for row in rows if row[2] != 'OFFBOARD')
    home_z = r.status().home[2]
    figures['rtl_return_alt_m'] = max(home_z - row[7] for row in rows)
    figures['peak_descent_mps'] = max(row[10] for row in rows)
    figures['landed_to_disarmed_s'] = r.until(lambda st: not st.armed, 20.0)
    r.run(2.0)
    return figures, r.trace


def auto_takeoff_land_profile(**kwargs):
    """Arm; NAV_TAKEOFF with NaN altitude; wait for AUTO.LOITER; 5 s; NAV_LAND; landed; disarmed."""
    r = Run(**kwargs)
    f = r.flight
    r.run(1.0)
    r.phase = 'takeoff'
    assert f.request_arming(True, False, r.t) == M.MAV_RESULT_ACCEPTED
    assert f.takeoff(NAN, r.origin.alt0, r.t) == M.MAV_RESULT_ACCEPTED
    figures = {'takeoff_to_loiter_s': r.until(lambda st: st.nav_mode == 'AUTO.LOITER', 30.0)}
    figures['takeoff_alt_reached_m'] = r.status().height
    r.run(5.0)
    r.phase = 'land'
    figures['land_start_height_m'] = r.status().height
    f.request_mode('AUTO.LAND', r.t)
    figures['nav_land_to_landed_s'] = r.until(lambda st: st.landed_state == M.MAV_LANDED_STATE_ON_GROUND, 60.0)
    figures['landed_to_disarmed_s'] = r.until(lambda st: not st.armed, 20.0)
    r.run(2.0)
    return figures, r.trace


def mission_profile(**kwargs):
    """MC_mission_box uploaded, AUTO.MISSION, arm: the item-reached times and arm -> landed."""
    r = Run(**kwargs)
    f = r.flight
    r.run(1.0)
    items = [Item(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, 1, 0.0, 0.0, 0.0, NAN, lat, lon, alt)
             for command, lat, lon, alt in MISSION_BOX]
    f.load_mission(items)
    assert f.request_mode('AUTO.MISSION', r.t) == M.MAV_RESULT_ACCEPTED
    r.run(0.5)
    r.phase = 'mission'
    r.events.clear()
    assert f.request_arming(True, False, r.t) == M.MAV_RESULT_ACCEPTED
    armed_s = r.t
    airborne = r.until(lambda st: st.landed_state != M.MAV_LANDED_STATE_ON_GROUND, 30.0)
    landed = r.until(lambda st: st.landed_state == M.MAV_LANDED_STATE_ON_GROUND, 150.0)
    figures = {'arm_to_landed_s': None if landed is None else airborne + landed}
    for t, event in r.events:
        if isinstance(event, ev.ItemReached):
            figures.setdefault('arm_to_item_%d_s' % event.seq, t - armed_s)
    figures['landed_to_disarmed_s'] = r.until(lambda st: not st.armed, 20.0)
    return figures, r.trace


# PX4's own mavros_posctl_test square (ENU x east, y north, z up), 1 m acceptance radius
POSCTL_SQUARE = ((50.0, 50.0, 20.0), (50.0, -50.0, 20.0), (-50.0, -50.0, 20.0), (0.0, 0.0, 20.0))


def posctl_square_profile(**kwargs):
    """PX4's posctl integration test: OFFBOARD and armed on the ground at (0, 0, 0), then the
    square's corners one after another, each held until within 1 m: the time of each leg."""
    r = Run(**kwargs)
    f = r.flight
    r.run(1.0)
    r.phase = 'square'
    r.setpoint = position_setpoint(0.0, 0.0, 0.0)
    r.run(0.5)
    f.request_mode('OFFBOARD', r.t)
    r.run(0.5)
    assert f.request_arming(True, False, r.t) == M.MAV_RESULT_ACCEPTED
    figures = {}
    for leg, (east, north, up) in enumerate(POSCTL_SQUARE, 1):
        r.setpoint = position_setpoint(north, east, -up)
        figures['leg_%d_s' % leg] = r.until(
            lambda st, target=(north, east, -up): math.dist(st.position, target) <= 1.0, 60.0)
    return figures, r.trace


def land_from_height_profile(height_m, **kwargs):
    """Take off to height_m (NAV_TAKEOFF), settle, AUTO.LAND: the time from the land command to landed."""
    r = Run(**kwargs)
    f = r.flight
    r.run(1.0)
    f.request_arming(True, False, r.t)
    f.takeoff(r.origin.alt0 + height_m, r.origin.alt0, r.t)
    r.until(lambda st: st.nav_mode == 'AUTO.LOITER', 60.0)
    r.run(8.0)
    r.phase = 'land'
    f.request_mode('AUTO.LAND', r.t)
    return {'land_to_landed_s': r.until(lambda st: st.landed_state == M.MAV_LANDED_STATE_ON_GROUND, 120.0)}, r.trace
