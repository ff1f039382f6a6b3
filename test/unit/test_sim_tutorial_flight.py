"""The tutorial flight on the simulated PX4's flight stack, offline, against the real-stack recordings
(reference/conversations/takeoff-mavros-px4 and takeoff-bridge-px4: real PX4 SITL, OFFBOARD at 2 m,
setpoints stopped -> AUTO.RTL, landing, disarm) and reference/px4-sitl-measured.md, "Turn 3
recordings", section 6: the land detector's word at takeoff and after the failsafe's landing, and
what HEARTBEAT, SYS_STATUS and EXTENDED_SYS_STATE say around the disarm."""

from offboard_py.dialect import mavlink
from offboard_py.sim import offboard_input
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.param_store import ParamStore
from offboard_py.testing.mavros_typemasks import POSITION_AND_YAW

from offboard_flight import SETPOINT_PERIOD_S, OffboardFlight

M = mavlink
# arm command -> EXTENDED_SYS_STATE landed_state IN_AIR: 17.970 - 16.109 s and 18.014 - 16.039 s
ARM_TO_IN_AIR_S = (1.86, 1.98)
# landed_state ON_GROUND -> disarmed (SYS_STATUS loses PREARM_CHECK with OFFBOARD back and no
# setpoint): 69.291 - 67.262 s and 70.201 - 68.180 s; COM_DISARM_LAND 2
LANDED_TO_DISARMED_S = (2.03, 2.02)
OFFBOARD = 0x00060000


class Tutorial(OffboardFlight):
    """The tutorial's node against a Flight: setpoints at 20 Hz, OFFBOARD, arm."""

    def __init__(self):
        super().__init__(ParamStore(), GeoOrigin(47.397742, 8.545594, 488.0))
        self.setpoint = offboard_input.offboard_setpoint(M.MAV_FRAME_LOCAL_NED, POSITION_AND_YAW, (0.0, 0.0, -2.0),
                                                         (0, 0, 0), (0, 0, 0), 0.0, 0.0, 0.0)

    def hover_then_stop(self):
        """Armed in OFFBOARD, climbed to 1.9 m, 10 s of hover, then the setpoints end (the failsafe)."""
        self.armed_in_offboard()
        self.until(lambda st: st.position[2] <= -1.9, 15.0, 'climb to 1.9 m')
        self.run(10.0)
        self.streaming = False

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
    tut.hover_then_stop()
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


# -- what PX4 sends to its own components in the failsafe (the recorded COMMAND_LONGs) -------------

# 1.365 s (56.622 - 55.257) and 1.287 s (57.173 - 55.886) after the last setpoint
LAST_SETPOINT_TO_GIMBAL_S = (1.287, 1.365)
# the idle item's command, 0.0-0.15 s from the landing's EXTENDED_SYS_STATE ON_GROUND (sampled at 5 Hz)
RECORDED_REPEATS_S = ((1.016, 1.529, 2.041), (1.025, 1.539, 2.054), (1.014, 1.526, 2.040), (1.013, 1.526, 2.040))
NAN_PARAM = float('nan')


def failsafe_flight():
    """The tutorial until disarmed; the navigator's vehicle commands with their times."""
    tut = Tutorial()
    tut.hover_then_stop()
    last_setpoint_s = tut.next_setpoint_s - SETPOINT_PERIOD_S
    commands, landed_s = [], None
    tut.texts = [e for e in tut.flight.take_events() if type(e).__name__ == 'StatusText']
    while tut.flight.status(tut.t).armed and tut.t < 200.0:
        st = tut.step()
        if landed_s is None and st.landed_state == M.MAV_LANDED_STATE_ON_GROUND:
            landed_s = tut.t
        events = tut.flight.take_events()
        commands += [(tut.t + e.delay_s, e) for e in events if type(e).__name__ == 'VehicleCommand']
        tut.texts += [e for e in events if type(e).__name__ == 'StatusText']
    tut.run(1.0)
    tut.texts += [e for e in tut.flight.take_events() if type(e).__name__ == 'StatusText']
    return tut, last_setpoint_s, landed_s, commands


def test_the_whole_flight_says_only_px4s_log_lines_which_never_reach_mavros():
    """PX4 main sent no STATUSTEXT on the onboard link in the recorded flights: its texts are events, but for
    its mavlink_log lines (Commander.cpp "Armed by", "Takeoff detected", "Landing detected", "Disarmed by";
    failsafe/framework.cpp notifyUser "Failsafe activated"), which a ground station gets (reference/
    px4-sitl-measured.md "Turn 4 recordings" item 6) and PX4's STATUSTEXT stream sends only where a GCS
    HEARTBEAT was heard (sim.mavlink.statustext): never to mavros."""
    tut = failsafe_flight()[0]
    assert [e.text for e in tut.texts if e.on_link] == ['Armed by external command\t', 'Takeoff detected\t',
                                                        'Failsafe activated\t', 'Landing detected\t',
                                                        'Disarmed by landing\t']


def test_the_failsafe_return_sends_the_gimbal_commands_and_the_landing_its_idle_item_as_px4():
    tut, last_setpoint_s, landed_s, commands = failsafe_flight()
    got = [(e.command, e.repeat) for _, e in commands]
    assert got == [(M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, True), (M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, False),
                   (M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, False), (0, True)], got
    gimbal_s = commands[0][0] - last_setpoint_s
    assert within(gimbal_s, LAST_SETPOINT_TO_GIMBAL_S), 'gimbal %.2f s after the last setpoint' % gimbal_s
    take, neutral, release, idle = [e.params for _, e in commands]
    assert take == (1.0, 1.0, -1.0, -1.0, 0.0, 0.0, 0.0) and release == (-3.0, -3.0, -1.0, -1.0, 0.0, 0.0, 0.0)
    assert all(p != p for p in neutral[:4]) and neutral[4:] == (2.0, 0.0, 0.0)
    home_amsl = tut.flight.navigator.mission.origin.alt0 - tut.flight.home[2]
    assert idle[:3] == (0.0, 2.0, 80.0) and idle[3] != idle[3] and idle[4:6] == (0.0, 0.0)
    assert abs(idle[6] - home_amsl) < 1e-6, 'param7: the home altitude AMSL (HOME_POSITION.altitude)'
    assert 0.0 <= commands[3][0] - landed_s <= 0.15


def test_the_autopilot_sends_a_vehicle_command_to_its_own_system_and_repeats_it_until_acknowledged():
    from offboard_py.sim import events as ev
    from offboard_py.sim.autopilot import SimulatedPx4

    class Clock(object):
        now = 1000.0

        def __call__(self):
            return self.now
    clock = Clock()
    ap = SimulatedPx4(bind_host='127.0.0.1', local_port=0, remote_port=9, gcs=False, ready_delay_s=0.0, clock=clock)
    sent = []
    ap.link.send = lambda msg: sent.append((clock.now, msg))
    try:
        ap.command_sender.send_vehicle_command(ev.VehicleCommand(0, (0.0, 2.0, 80.0, NAN_PARAM, 0.0, 0.0, 490.0), True))
        for _ in range(3000):
            clock.now += 0.001
            ap.command_sender.send_deferred()
        times = [t - 1000.0 for t, _ in sent]
        assert [m.confirmation for _, m in sent] == [0, 1, 2, 3]
        assert {(m.target_system, m.target_component, m.command) for _, m in sent} == {(ap.system_id, 0, 0)}
        for i in (1, 2, 3):
            assert min(r[i - 1] for r in RECORDED_REPEATS_S) * 0.9 <= times[i] <= \
                max(r[i - 1] for r in RECORDED_REPEATS_S) * 1.1, times
        del sent[:]
        ap.command_sender.send_vehicle_command(ev.VehicleCommand(M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, (1.0,) * 7, True))
        ap.command_sender.send_deferred()
        ack = ap.mav.command_ack_encode(M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, M.MAV_RESULT_ACCEPTED, 0, 0,
                                        ap.system_id, 1)
        ap.command_sender.on_command_ack(ack)
        for _ in range(3000):
            clock.now += 0.001
            ap.command_sender.send_deferred()
        assert [m.confirmation for _, m in sent] == [0], 'acknowledged: no repeats'
    finally:
        ap.close_links()
