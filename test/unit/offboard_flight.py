"""A simulated PX4 Flight on its own clock with an offboard companion streaming its setpoint at 20 Hz,
as the tutorial's node does. Not a test module: the offline tests import it."""

from offboard_py.sim.flight import Flight

DT = 0.01
SETPOINT_PERIOD_S = 0.05  # the tutorial's 20 Hz


class OffboardFlight:
    """`setpoint` (None: nothing streamed) goes to the flight every SETPOINT_PERIOD_S while `streaming`."""

    def __init__(self, params, origin, **flight_args):
        self.flight = Flight(params, origin, 0.0, ready_delay_s=0.0, **flight_args)
        self.t = 0.0
        self.setpoint = None
        self.streaming = True
        self.next_setpoint_s = 0.0

    def step(self):
        if self.streaming and self.setpoint is not None and self.t >= self.next_setpoint_s - 1e-9:
            self.flight.on_offboard_setpoint(self.setpoint, self.t)
            self.next_setpoint_s = self.t + SETPOINT_PERIOD_S
        self.t += DT
        self.flight.step(self.t, DT)
        return self.flight.status(self.t)

    def run(self, seconds):
        for _ in range(int(round(seconds / DT))):
            self.step()

    def until(self, condition, timeout_s, what):
        """Seconds until condition(status) holds; AssertionError naming `what` after timeout_s."""
        start = self.t
        while self.t - start < timeout_s:
            if condition(self.step()):
                return self.t - start
        raise AssertionError('no %s within %.0f s: %s' % (what, timeout_s, self.flight.status(self.t)))
