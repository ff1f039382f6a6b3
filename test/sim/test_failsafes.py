"""The failsafes as a ground station sees them on the simulated PX4's GCS link, caused by the test kit's
Failures (offboard_py.testing.failures) over UDP: the battery switched off held to the real PX4 SITL recording
(reference/px4-sitl-battery-off.json, px4-sitl-measured.md "Turn 4 recordings" item 6) message by message,
SYS_FAILURE_EN, the data link, the geofence upload and GPS."""

import json
import math
import os

import pytest

from offboard_py.dialect import mavlink
from offboard_py.testing.failures import Failures
from offboard_py.testing.sim_client import ACCEPTED, DENIED

REFERENCE = os.path.join(os.path.dirname(__file__), '..', '..', 'reference')
TOLERANCE = 0.25  # of the recorded time
LANDING_BEGINS_S = 8.2  # the recording's rows up to AUTO.LAND are held (test/unit/test_sim_failsafes.py)
NAN = float('nan')


@pytest.fixture
def gcs(start_sim):
    """(sim, Failures) on the simulator's GCS link, ready to arm."""
    sim, _ = start_sim('--ready-delay', '1', connect=False)
    failures = Failures(sim.instance)
    try:
        failures.connected(10.0)
        failures.client.wait_for(lambda: failures.latest['HEARTBEAT'].system_status == mavlink.MAV_STATE_STANDBY,
                                 5.0, 'ready')
        yield sim, failures
    finally:
        failures.close()


def take_off_and_hold(failures, hold_s):
    client = failures.client
    assert client.arm() == ACCEPTED
    assert client.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, NAN)[0] == ACCEPTED
    client.wait_for(lambda: client.mode() == 'AUTO.LOITER' and client.latest['EXTENDED_SYS_STATE'].landed_state
                    == mavlink.MAV_LANDED_STATE_IN_AIR, 20.0, 'AUTO.LOITER in the air')
    client.sleep(hold_s)


def test_battery_off_as_a_ground_station_saw_it_on_px4(gcs):
    _, failures = gcs
    with open(os.path.join(REFERENCE, 'px4-sitl-battery-off.json')) as f:
        recorded = json.load(f)['seconds_from_the_injection']
    take_off_and_hold(failures, 5.0)
    t0 = failures.now()
    assert failures.battery_off() == ACCEPTED
    failures.wait_mode('AUTO.LAND', 15.0)
    failures.client.sleep(1.0)
    client = failures.client

    def first(msg_type, condition):
        return next((t - t0 for t, m in client.received(msg_type) if t >= t0 and condition(m)), None)
    for row in recorded:
        if row['t'] > LANDING_BEGINS_S or row['message'] == 'COMMAND_ACK':
            continue
        if row['message'] == 'STATUSTEXT':
            # on the wire PX4 ends these lines with a tab (they go out as events too); the recording shows them without
            got = first('STATUSTEXT', lambda m: m.text == row['text'] + '\t' and m.severity == row['severity'])
        elif row['message'] == 'SYS_STATUS':
            got = first('SYS_STATUS', lambda m: not m.onboard_control_sensors_health & row['health_lost'])
        elif row['message'] == 'EXTENDED_SYS_STATE':
            got = first('EXTENDED_SYS_STATE', lambda m: m.landed_state == row['landed_state'])
        elif 'system_status' in row:
            got = first('HEARTBEAT', lambda m: m.get_srcComponent() == 1 and m.system_status == row['system_status'])
        else:
            got = next((t - t0 for t, mode, _ in failures.modes(t0) if mode == row['mode']), None)
        assert got is not None, 'never: %s; texts %s' % (row, failures.texts(t0))
        assert abs(got - row['t']) <= TOLERANCE * row['t'], '%s at %.2f s, PX4 %.2f s' % (
            row.get('text') or row['what'], got, row['t'])
    battery = client.latest['BATTERY_STATUS']
    assert battery.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY and battery.battery_remaining < 5


def test_failure_injection_needs_sys_failure_en(gcs):
    """mavlink_receiver.cpp: MAV_CMD_INJECT_FAILURE is DENIED unless SYS_FAILURE_EN is 1 (PX4 SITL's value);
    a unit no module of PX4 takes gets no answer."""
    _, failures = gcs
    assert failures.set_param('SYS_FAILURE_EN', 0) == 0
    assert failures.battery_off() == DENIED
    assert failures.set_param('SYS_FAILURE_EN', 1) == 1
    assert failures.inject(mavlink.FAILURE_UNIT_SYSTEM_RC_SIGNAL, mavlink.FAILURE_TYPE_OFF, timeout_s=1.0) is None
    assert failures.gps_off() == ACCEPTED and failures.gps_on() == ACCEPTED


def test_set_battery_percentage_low_warns_only(gcs):
    _, failures = gcs
    take_off_and_hold(failures, 1.0)
    t0 = failures.now()
    assert failures.set_battery(14) == 14.0
    failures.wait_text('Low battery', 10.0, since=t0)
    failures.client.wait_for(lambda: failures.latest['BATTERY_STATUS'].battery_remaining == 14
                             and failures.latest['BATTERY_STATUS'].charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_LOW,
                             8.0, 'BATTERY_STATUS at 14 %, LOW')
    assert failures.client.mode() == 'AUTO.LOITER' and failures.latest['HEARTBEAT'].system_status == \
        mavlink.MAV_STATE_ACTIVE, 'LOW warns, no failsafe'
    failures.restore_battery()
    assert failures.client.read_param('SIM_BAT_MIN_PCT').param_value == 50.0


def test_data_link_loss_with_nav_dll_act_return(gcs):
    _, failures = gcs
    assert failures.set_param('NAV_DLL_ACT', 2) == 2
    failures.client.sleep(2.5)  # PX4 counts a ground station once its telemetry_status check (1.25 s) saw it
    take_off_and_hold(failures, 1.0)
    failures.cut_data_link()  # the vehicle goes on sending to this ground station, which stops its HEARTBEATs
    cut = failures.now()
    failures.wait_mode('AUTO.RTL', 10.0 + 2.5 + 5.0 + 2.0)
    when = next(t for t, mode, _ in failures.modes(cut) if mode == 'AUTO.RTL') - cut
    # the last HEARTBEAT up to a period before the cut, counted 1.25-2.5 s longer by telemetry_status's checks
    assert 10.0 + 1.25 - 1.0 + 5.0 <= when <= 10.0 + 2.5 + 5.0 + 1.2, \
        'lost after COM_DL_LOSS_T, then Hold 5 s: Return %.2f s after the cut' % when
    assert failures.latest['HEARTBEAT'].system_status == mavlink.MAV_STATE_CRITICAL
    failures.restore_data_link()
    failures.wait_text('GCS connection regained', 5.0, since=cut)


def test_fence_upload_and_breach(gcs):
    sim, failures = gcs
    assert failures.upload_fence(failures.fence_circle(5.0)) == mavlink.MAV_MISSION_ACCEPTED
    client = failures.client
    take_off_and_hold(failures, 1.0)
    home = failures.home()
    lat = home[0] + 10.0 / 111195.0  # 10 m north
    assert client.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, NAN, lat, home[1], home[2] + 2.5)[0] == ACCEPTED
    t0 = failures.now()
    failures.wait_text('Geofence: approaching or outside geofence', 15.0, since=t0)
    client.sleep(3.0)
    north = client.latest['LOCAL_POSITION_NED'].x
    assert 4.0 <= north <= 8.0, 'held at %.1f m north, the fence at 5 m' % north
    assert client.mode() == 'AUTO.LOITER' and math.isfinite(north)
