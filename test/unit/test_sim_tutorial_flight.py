"""The tutorial flight on the simulated PX4's flight stack, offline, against the real-stack recordings
(reference/conversations/takeoff-mavros-px4 and takeoff-bridge-px4: real PX4 SITL, OFFBOARD at 2 m,
setpoints stopped -> AUTO.RTL, landing, disarm) and reference/px4-sitl-measured.md, "Turn 3
recordings", section 6: the land detector's word at takeoff and after the failsafe's landing, and
what HEARTBEAT, SYS_STATUS and EXTENDED_SYS_STATE say around the disarm."""

from offboard_py.dialect import mavlink
from offboard_py.sim import offboard_input
from offboard_py.sim.flight import Flight
from offboard_py.sim.geo import LocalFrame
from offboard_py.sim.params import ParamStore
from offboard_py.testing.typemask import POSITION_AND_YAW

M = mavlink
DT = 0.01
SETPOINT_PERIOD_S = 0.05  # the tutorial's 20 Hz
# arm command -> EXTENDED_SYS_STATE landed_state IN_AIR: 17.970 - 16.109 s and 18.014 - 16.039 s
ARM_TO_IN_AIR_S = (1.86, 1.98)
# landed_state ON_GROUND -> disarmed (SYS_STATUS loses PREARM_CHECK with OFFBOARD back and no
# setpoint): 69.291 - 67.262 s and 70.201 - 68.180 s; COM_DISARM_LAND 2
LANDED_TO_DISARMED_S = (2.03, 2.02)
OFFBOARD = 0x00060000


class Tutorial:
    """The tutorial's node against a Flight: setpoints at 20 Hz, OFFBOARD, arm."""

    def __init__(self):
        self.flight = Flight(ParamStore(), LocalFrame(47.397742, 8.545594, 488.0), 0.0, ready_delay_s=0.0)
        self.t = 0.0
        self.streaming = True
        self._next_s = 0.0
        self.setpoint = offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW, (0.0, 0.0, -2.0),
                                                         (0, 0, 0), (0, 0, 0), 0.0, 0.0, 0.0)

    def step(self):
        if self.streaming and self.t >= self._next_s - 1e-9:
            self.flight.on_offboard_setpoint(self.setpoint, self.t)
            self._next_s = self.t + SETPOINT_PERIOD_S
        self.t += DT
        self.flight.step(self.t, DT)
        return self.flight.status(self.t)

    def run(self, seconds):
        for _ in range(int(round(seconds / DT))):
            self.step()

    def until(self, condition, timeout_s, what):
        start = self.t
        while self.t - start < timeout_s:
            st = self.step()
            if condition(st):
                return self.t - start
        raise AssertionError('no %s within %.0f s: %s' % (what, timeout_s, self.flight.status(self.t)))

    def armed_in_offboard(self):
        self.run(1.0)
        assert self.flight.request_mode('OFFBOARD', self.t) == M.MAV_RESULT_ACCEPTED
        self.run(5.0)
        assert self.flight.request_arming(True, False, self.t) == M.MAV_RESULT_ACCEPTED


def within(value, recorded, tolerance=0.1):
    return min(recorded) * (1 - tolerance) <= value <= max(recorded) * (1 + tolerance)


def test_the_land_detector_says_in_air_early_in_the_takeoff_ramp_as_px4():
    tut = Tutorial()
    tut.armed_in_offboard()
    took = tut.until(lambda st: st.landed_state != M.MAV_LANDED_STATE_ON_GROUND, 10.0, 'landed_state change')
    assert tut.flight.status(tut.t).landed_state == M.MAV_LANDED_STATE_IN_AIR
    assert within(took, ARM_TO_IN_AIR_S), 'arm -> IN_AIR %.2f s, PX4 %s s' % (took, ARM_TO_IN_AIR_S)


def test_a_disarm_1_9_s_after_an_offboard_arm_is_temporarily_rejected_and_the_climb_goes_on():
    tut = Tutorial()
    tut.armed_in_offboard()
    tut.run(1.9)
    assert tut.flight.request_arming(False, False, tut.t) == M.MAV_RESULT_TEMPORARILY_REJECTED, \
        'PX4 rejects it: the takeoff ramp has passed the land detector\'s minimal thrust'
    tut.until(lambda st: st.position[2] <= -1.9, 15.0, 'climb to 1.9 m')
    assert tut.flight.status(tut.t).armed


def test_after_the_failsafe_landing_px4_disarms_and_reports_offboard_uninit_and_no_prearm():
    tut = Tutorial()
    tut.armed_in_offboard()
    tut.until(lambda st: st.position[2] <= -1.9, 15.0, 'climb to 1.9 m')
    tut.run(10.0)
    tut.streaming = False
    states, landed_s = [tut.flight.status(tut.t).landed_state], None
    while tut.flight.status(tut.t).armed:
        st = tut.step()
        if st.landed_state != states[-1]:
            states.append(st.landed_state)
            if st.landed_state == M.MAV_LANDED_STATE_ON_GROUND:
                landed_s = tut.t
        assert tut.t < 200.0, 'never disarmed: %s' % (st,)
    # the recordings: IN_AIR, LANDING while the return lands, ON_GROUND; no TAKEOFF or other state
    assert states == [M.MAV_LANDED_STATE_IN_AIR, M.MAV_LANDED_STATE_LANDING, M.MAV_LANDED_STATE_ON_GROUND], states
    took = tut.t - landed_s
    assert within(took, LANDED_TO_DISARMED_S), 'landed -> disarmed %.2f s, PX4 %s' % (took, LANDED_TO_DISARMED_S)
    st = tut.flight.status(tut.t)
    # HEARTBEAT base_mode 17, custom_mode 0x60000, system_status 0; CURRENT_MODE 0x60000 / 0x60000;
    # SYS_STATUS health 0x0320C83F (PREARM_CHECK cleared: OFFBOARD selected, no setpoint)
    assert (st.base_mode, st.custom_mode, st.intended_custom_mode) == (17, OFFBOARD, OFFBOARD)
    assert st.system_status == M.MAV_STATE_UNINIT and not st.prearm_ok
    assert st.landed_state == M.MAV_LANDED_STATE_ON_GROUND
