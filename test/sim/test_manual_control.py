"""MANUAL_CONTROL over UDP on the simulated PX4's GCS link, as a ground station's joystick flies it: the arming refusal
with the throttle up and the climb and hold in POSCTL held to real PX4 SITL SIH
(reference/px4-sitl-manual-control.json, whose source says how it was recorded). The joystick sends to target 0, as
PX4's receiver takes it too (mavlink_receiver.cpp, handle_message_manual_control)."""

import threading

import pytest

from offboard_py.testing.failures import Failures
from offboard_py.testing.reference import load
from offboard_py.testing.sim_client import ACCEPTED

REFERENCE = load('px4-sitl-manual-control.json')
CENTRED = (0, 0, 500, 0)


class Joystick:
    """MANUAL_CONTROL (x, y, z, r = `sticks`) every client period of the recording, to target 0."""

    def __init__(self, failures):
        self.failures = failures
        self.sticks = CENTRED
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        client, clock = self.failures.client, self.failures.clock
        period_s = REFERENCE['client']['manual_control_period_s']
        while not self._stop.is_set():
            x, y, z, r = self.sticks
            client.send(client.mav.manual_control_encode(0, x, y, z, r, 0))
            self._stop.wait(clock.wall_s(period_s))

    def close(self):
        self._stop.set()
        self._thread.join(timeout=2.0)


@pytest.fixture
def joystick(start_sim):
    """(Failures, Joystick) on the simulator's GCS link, ready to arm."""
    sim, _ = start_sim('--ready-delay', '1', connect=False)
    failures = Failures(sim.instance)
    stick = Joystick(failures)
    try:
        failures.connected(10.0)
        failures.client.wait_for(lambda: failures.client.latest.get('SYS_STATUS') is not None, 5.0, 'SYS_STATUS')
        failures.client.sleep(1.5)
        yield failures, stick
    finally:
        stick.close()
        failures.close()


def test_posctl_refuses_the_throttle_up_then_climbs_and_holds(joystick):
    failures, stick = joystick
    client = failures.client
    refusal = REFERENCE['arming']['posctl_throttle_800']
    assert client.set_mode('POSCTL') == ACCEPTED
    stick.sticks = (0, 0, 800, 0)
    client.sleep(0.5)
    since = failures.now()
    assert client.arm() == refusal['result']
    failures.wait_text(refusal['text'], 2.0, since)
    stick.sticks = CENTRED
    client.sleep(0.5)
    assert client.arm() == ACCEPTED
    client.sleep(2.0)
    ground_z = client.z()
    climb_s = next(seconds for name, _, seconds, _ in REFERENCE['profile']['flight'] if name == 'climb')
    stick.sticks = (0, 0, 800, 0)
    client.sleep(climb_s)
    stick.sticks = CENTRED
    height = ground_z - client.z()
    recorded = REFERENCE['ulog']['takeoff']['truth_height_end_m']
    assert 0.75 * min(recorded) <= height <= 1.25 * max(recorded), 'climbed %.2f m, PX4 SITL %s' % (height, recorded)
    client.sleep(3.0)
    held = client.z()
    client.sleep(3.0)
    assert abs(client.z() - held) <= 0.3, 'altitude held: %.2f -> %.2f' % (held, client.z())
    assert client.mode() == 'POSCTL' and client.armed()
