"""The tutorial's request sequence, driven by hand: state and time in, requests out."""

import pytest

from offboard_py.offboard import DISCONNECTED, OffboardLogic, Request, VehicleState

CONNECTED = VehicleState(True, False, 'AUTO.LOITER')
OFFBOARD_DISARMED = VehicleState(True, False, 'OFFBOARD')
FLYING = VehicleState(True, True, 'OFFBOARD')


def prestreamed(logic, t=0.0, count=None):
    """Connect and send the whole pre-stream at 20 Hz; return the time after it."""
    logic.on_state(CONNECTED)
    for _ in range(logic.prestream_count if count is None else count):
        logic.on_setpoint_sent(t)
        t += 0.05
    return t


def test_nothing_before_connected():
    logic = OffboardLogic()
    logic.on_state(DISCONNECTED)
    for i in range(500):
        logic.on_setpoint_sent(i * 0.05)
        assert logic.next_request(i * 0.05) is None
    assert not logic.should_stream()
    assert logic.setpoints_sent == 0


def test_streaming_starts_at_connection_and_never_stops():
    logic = OffboardLogic()
    assert not logic.should_stream()
    logic.on_state(CONNECTED)
    assert logic.should_stream()
    logic.on_state(DISCONNECTED)
    assert logic.should_stream(), 'a lost link must not stop the stream'


@pytest.mark.parametrize('count', [0, 1, 100, 250])
def test_exactly_prestream_count_setpoints_before_first_request(count):
    """At 20 Hz: no request before the count-th setpoint, the first one 5 s after it."""
    logic = OffboardLogic(prestream_count=count, request_interval_s=5.0)
    logic.on_state(CONNECTED)
    first_request_tick = None
    for tick in range(count + 200):
        t = tick / 20.0
        if logic.next_request(t) is not None:
            first_request_tick = tick
            break
        assert logic.setpoints_sent < count or count == 0 or logic.prestream_done()
        logic.on_setpoint_sent(t)
    assert first_request_tick is not None, 'no request at all'
    last_prestream_tick = max(count - 1, 0)  # with no pre-stream, the interval starts at once
    assert first_request_tick - last_prestream_tick == 100
    assert logic.setpoints_sent == first_request_tick >= count


def test_no_request_until_prestream_complete_even_after_long_time():
    logic = OffboardLogic(prestream_count=100)
    prestreamed(logic, count=99)
    assert logic.next_request(1000.0) is None
    logic.on_setpoint_sent(1000.0)
    assert logic.next_request(1000.0) is None, 'interval counts from the end of the pre-stream'
    assert logic.next_request(1005.0) is Request.SET_OFFBOARD


def test_offboard_before_arming_and_requests_spaced():
    logic = OffboardLogic(prestream_count=100, request_interval_s=5.0)
    t = prestreamed(logic)
    assert logic.next_request(t + 4.9) is None
    assert logic.next_request(t + 5.0) is Request.SET_OFFBOARD
    logic.on_request_done(t + 5.2)  # the spacing counts from the answer
    logic.on_state(OFFBOARD_DISARMED)
    assert logic.next_request(t + 10.1) is None
    assert logic.next_request(t + 10.25) is Request.ARM
    logic.on_request_done(t + 10.3)
    logic.on_state(FLYING)
    assert logic.next_request(t + 100.0) is None


def test_refused_request_is_retried_after_interval():
    logic = OffboardLogic()
    t = prestreamed(logic)
    assert logic.next_request(t + 5) is Request.SET_OFFBOARD
    logic.on_request_done(t + 5)
    assert logic.next_request(t + 9.99) is None
    assert logic.next_request(t + 10) is Request.SET_OFFBOARD


def test_rerequest_after_mode_drops():
    logic = OffboardLogic()
    t = prestreamed(logic)
    logic.on_request_done(t + 5)
    logic.on_state(FLYING)
    assert logic.next_request(t + 20) is None
    lines = logic.on_state(VehicleState(True, True, 'AUTO.RTL'))
    assert lines == ['Vehicle left OFFBOARD (now AUTO.RTL)']
    assert logic.next_request(t + 20) is Request.SET_OFFBOARD


def test_no_request_while_link_down():
    logic = OffboardLogic()
    t = prestreamed(logic)
    logic.on_state(DISCONNECTED)
    assert logic.next_request(t + 60) is None
    logic.on_state(CONNECTED)
    assert logic.next_request(t + 60) is Request.SET_OFFBOARD


def test_transitions_logged_once():
    logic = OffboardLogic()
    assert logic.on_state(CONNECTED) == ['FCU connected']
    assert logic.on_state(CONNECTED) == []
    assert logic.on_state(OFFBOARD_DISARMED) == ['OFFBOARD enabled']
    assert logic.on_state(OFFBOARD_DISARMED) == []
    assert logic.on_state(FLYING) == ['Vehicle armed']
    assert logic.on_state(FLYING) == []


def test_default_fights_the_pilot():
    logic = OffboardLogic(respect_pilot=False)
    t = prestreamed(logic)
    logic.on_state(FLYING)
    logic.on_state(VehicleState(True, True, 'AUTO.LOITER'))
    assert logic.next_request(t + 10) is Request.SET_OFFBOARD


def test_respect_pilot_stops_requests_after_takeover():
    logic = OffboardLogic(respect_pilot=True)
    t = prestreamed(logic)
    logic.on_state(FLYING)
    lines = logic.on_state(VehicleState(True, True, 'AUTO.LOITER'))
    assert any('Pilot took over' in line for line in lines)
    for k in range(100):
        assert logic.next_request(t + 10 + k) is None
    assert logic.on_state(VehicleState(True, False, 'AUTO.LOITER')) == ['Vehicle disarmed'], \
        'the take-over is logged once'
    assert logic.should_stream()


def test_respect_pilot_still_brings_vehicle_up_first():
    logic = OffboardLogic(respect_pilot=True)
    t = prestreamed(logic)
    assert logic.next_request(t + 5) is Request.SET_OFFBOARD
    logic.on_request_done(t + 5)
    logic.on_state(VehicleState(True, False, 'AUTO.LOITER'))  # refused: not yet a take-over
    assert logic.next_request(t + 10) is Request.SET_OFFBOARD


def test_respect_pilot_disarm_counts_as_takeover():
    logic = OffboardLogic(respect_pilot=True)
    t = prestreamed(logic)
    logic.on_state(FLYING)
    logic.on_state(VehicleState(True, False, 'OFFBOARD'))
    assert logic.next_request(t + 60) is None


def test_stops_arming_a_vehicle_that_keeps_disarming_itself():
    """_z:=-5: PX4 arms, never takes off, disarms after COM_DISARM_PRFLT (10 s); the tutorial's
    loop would re-arm it every 10 s forever. After 3 such disarms in a row the node stops."""
    logic = OffboardLogic()
    t = prestreamed(logic)
    logic.on_state(OFFBOARD_DISARMED)
    lines = []
    for cycle in range(4):
        t += 5.0
        assert logic.next_request(t) == (Request.ARM if cycle < 3 else None), 'cycle %d' % cycle
        if cycle == 3:
            break
        logic.on_request_done(t)
        logic.on_state(FLYING)
        for _ in range(200):  # 10 s armed on the ground
            t += 0.05
            logic.on_setpoint_sent(t)
        lines += logic.on_state(OFFBOARD_DISARMED)
    assert any('disarmed itself 3 times' in line for line in lines), lines
    logic.on_state(CONNECTED)
    assert logic.next_request(t + 10.0) == Request.SET_OFFBOARD, 'OFFBOARD is still asked for'


def test_a_vehicle_that_flew_is_armed_again_after_landing():
    logic = OffboardLogic()
    t = prestreamed(logic)
    logic.on_state(OFFBOARD_DISARMED)
    for cycle in range(5):  # each time it stays armed 60 s (it flew), then disarms on landing
        t += 5.0
        assert logic.next_request(t) == Request.ARM, 'cycle %d' % cycle
        logic.on_request_done(t)
        logic.on_state(FLYING)
        for _ in range(1200):
            t += 0.05
            logic.on_setpoint_sent(t)
        logic.on_state(OFFBOARD_DISARMED)
    assert not logic.gave_up_arming


def test_a_request_taken_is_not_due_again_until_it_is_done():
    """The stream thread takes a request and hands it to the main thread: while the service call is out
    (mavros may take 5 s to answer cmd/arming), no second one is due, however long it takes."""
    logic = OffboardLogic()
    t = prestreamed(logic)
    assert logic.next_request(t + 5) is Request.SET_OFFBOARD, 'asking takes nothing'
    assert logic.next_request(t + 5) is Request.SET_OFFBOARD
    assert logic.take_request(t + 5) is Request.SET_OFFBOARD
    for k in range(100):  # the stream asks at every setpoint while the call is out
        assert logic.take_request(t + 5.05 + 0.05 * k) is None, 'one request at a time (tick %d)' % k
    assert logic.next_request(t + 30) is None and logic.take_request(t + 30) is None, 'one request at a time'
    logic.on_request_done(t + 31)
    assert logic.next_request(t + 35.9) is None
    assert logic.take_request(t + 36) is Request.SET_OFFBOARD, 'a full interval after the answer'
