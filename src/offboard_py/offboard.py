"""Decision logic of the offboard node: when to stream, when to ask for OFFBOARD, when to arm.

This is the PX4 tutorial's main loop as a pure state machine: it is given the vehicle
state and the time, and it answers with what to do. It never touches ROS, a clock or
a socket, so every rule is testable offline. `offb_node` wires it to rospy.

The rules, as in the tutorial:
- nothing is streamed or requested before the FCU is connected;
- after the connection, `prestream_count` setpoints are streamed before any request;
- then, at most one request every `request_interval_s`: OFFBOARD first while the mode
  is not OFFBOARD, otherwise arming while disarmed. The spacing counts from the end of
  the previous request, whatever its answer;
- setpoints keep streaming for as long as the node runs.

Additions (documented in README): no request while the link is down; the opt-in
`respect_pilot`: once the vehicle has been in OFFBOARD and armed, a mode change or a
disarm by someone else ends all further requests instead of undoing the pilot's choice;
and no endless re-arming: when the vehicle disarms itself QUICK_DISARMS_MAX times in a
row, each within QUICK_DISARM_S of arming (PX4 disarms a vehicle that does not take off
after COM_DISARM_PRFLT, e.g. when ~z is below the ground), the node stops arming it.
"""

import enum
import math
from collections import namedtuple

OFFBOARD = 'OFFBOARD'
# PX4 leaves OFFBOARD when setpoints stop for COM_OF_LOSS_T; it needs them faster than 2 Hz.
MIN_RATE_HZ = 2.0
# A vehicle that disarms this many times in a row, each time within QUICK_DISARM_S of being
# seen armed, is not armed again.
QUICK_DISARMS_MAX = 3
QUICK_DISARM_S = 30.0
# Times are floats: an interval that is due within a microsecond counts as due.
_TIME_TOLERANCE_S = 1e-6

VehicleState = namedtuple('VehicleState', 'connected armed mode')
VehicleState.__doc__ = 'What mavros/state says: connected (bool), armed (bool), mode (str).'
DISCONNECTED = VehicleState(False, False, '')


class Request(enum.Enum):
    SET_OFFBOARD = 'set_mode OFFBOARD'
    ARM = 'arm'


class ParamError(ValueError):
    """A node parameter with a value outside what the node accepts; names the parameter."""

    def __init__(self, name, message):
        super().__init__('parameter ~%s: %s' % (name, message))
        self.name = name


Config = namedtuple('Config', 'rate_hz prestream_count request_interval_s x y z yaw frame_id respect_pilot')
Config.__doc__ = 'Validated node parameters. Position is ENU (m), yaw is ENU (rad, 0 = east).'

# The tutorial's values: 20 Hz, 100 setpoints first, requests 5 s apart, hover at 2 m.
DEFAULTS = Config(rate_hz=20.0, prestream_count=100, request_interval_s=5.0,
                  x=0.0, y=0.0, z=2.0, yaw=0.0, frame_id='', respect_pilot=False)


def _number(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParamError(name, 'expected a number, got %r' % (value,))
    if not math.isfinite(value):
        raise ParamError(name, 'expected a finite number, got %r' % (value,))
    return float(value)


def validate_config(get):
    """Read and check every parameter through `get(name, default)`; return a Config.

    Raises ParamError naming the first bad parameter and the allowed range.
    """
    rate_hz = _number('rate', get('rate', DEFAULTS.rate_hz))
    if rate_hz <= MIN_RATE_HZ:
        raise ParamError('rate', 'must be above %g Hz (PX4 leaves OFFBOARD when setpoints '
                                 'come slower), got %g' % (MIN_RATE_HZ, rate_hz))
    count = get('prestream_count', DEFAULTS.prestream_count)
    if isinstance(count, bool) or not isinstance(count, int):
        raise ParamError('prestream_count', 'expected a whole number, got %r' % (count,))
    if count < 0:
        raise ParamError('prestream_count', 'must be 0 or more, got %d' % count)
    interval = _number('request_interval', get('request_interval', DEFAULTS.request_interval_s))
    if interval < 0:
        raise ParamError('request_interval', 'must be 0 s or more, got %g' % interval)
    x, y, z, yaw = (_number(n, get(n, getattr(DEFAULTS, n))) for n in ('x', 'y', 'z', 'yaw'))
    frame_id = get('frame_id', DEFAULTS.frame_id)
    if not isinstance(frame_id, str):
        raise ParamError('frame_id', 'expected a string, got %r' % (frame_id,))
    respect_pilot = get('respect_pilot', DEFAULTS.respect_pilot)
    if not isinstance(respect_pilot, bool):
        raise ParamError('respect_pilot', 'expected true or false, got %r' % (respect_pilot,))
    return Config(rate_hz, count, interval, x, y, z, yaw, frame_id, respect_pilot)


class OffboardLogic:
    """The tutorial's request sequence as a state machine.

    Feed it `on_state()` for every mavros/state message and `on_setpoint_sent()` for every
    setpoint published. `next_request(now_s)` only answers what is due; `take_request(now_s)`
    takes it (no other is due until `on_request_done(now_s)` says the service call returned).
    Times are seconds on any monotonic clock. `on_state()` returns the log lines a transition
    deserves.
    """

    def __init__(self, prestream_count=DEFAULTS.prestream_count,
                 request_interval_s=DEFAULTS.request_interval_s, respect_pilot=False):
        self.prestream_count = prestream_count
        self.request_interval_s = request_interval_s
        self.respect_pilot = respect_pilot
        self.state = DISCONNECTED
        self.fcu_seen = False         # the FCU has been connected once: from then on, the stream flows
        self.setpoints_sent = 0
        self.prestream_complete = False
        self.last_request_s = None    # when the last request came back (or the pre-stream ended)
        self.in_flight = None         # the request taken and not yet done
        self.flying_offboard = False  # has been in OFFBOARD and armed at once
        self.pilot_took_over = False
        self.armed_since_s = None     # when a setpoint first went out with the vehicle armed
        self.quick_disarms = 0        # disarms in a row soon after arming
        self.gave_up_arming = False

    def on_state(self, state):
        """Take a new vehicle state; return the messages to log for what changed."""
        old, self.state = self.state, state
        lines = []
        if state.connected and not old.connected:
            lines.append('FCU connected' if not self.fcu_seen else 'FCU connection back')
            self.fcu_seen = True
        elif old.connected and not state.connected:
            lines.append('FCU connection lost')
        if state.connected:
            if state.mode == OFFBOARD and old.mode != OFFBOARD:
                lines.append('OFFBOARD enabled')
            elif old.mode == OFFBOARD and state.mode != OFFBOARD and old.connected:
                lines.append('Vehicle left OFFBOARD (now %s)' % (state.mode or 'unknown'))
            if state.armed and not old.armed:
                lines.append('Vehicle armed')
            elif old.armed and not state.armed and old.connected:
                lines.append('Vehicle disarmed')
                lines += self._count_quick_disarm()
        if state.connected and state.armed and state.mode == OFFBOARD:
            self.flying_offboard = True
        elif (self.respect_pilot and self.flying_offboard and state.connected
              and not self.pilot_took_over):
            self.pilot_took_over = True
            lines.append('Pilot took over (mode %s, %s): no further requests'
                         % (state.mode, 'armed' if state.armed else 'disarmed'))
        return lines

    def _count_quick_disarm(self):
        """A disarm while the armed spell was short (the flight, if any, reset the count)."""
        self.armed_since_s = None
        self.quick_disarms += 1
        if self.quick_disarms >= QUICK_DISARMS_MAX and not self.gave_up_arming:
            self.gave_up_arming = True
            return ['Vehicle disarmed itself %d times within %.0f s of arming: not arming it again '
                    '(does it take off? check ~z and the FCU\'s messages)' % (self.quick_disarms, QUICK_DISARM_S)]
        return []

    def should_stream(self):
        """Setpoints flow once the FCU has been connected, and from then on always."""
        return self.fcu_seen

    def on_setpoint_sent(self, now_s):
        if not self.fcu_seen:
            return
        self.setpoints_sent += 1
        if self.state.armed:
            if self.armed_since_s is None:
                self.armed_since_s = now_s
            elif now_s - self.armed_since_s >= QUICK_DISARM_S:
                self.quick_disarms = 0  # it stayed armed: it flew
        if not self.prestream_complete and self.setpoints_sent >= self.prestream_count:
            self.prestream_complete = True
            self.last_request_s = now_s  # the tutorial's `last_req = now()` after the pre-stream

    def prestream_done(self):
        return self.prestream_complete

    def next_request(self, now_s):
        """The request due now, or None. Asks only: take_request() takes it."""
        if (not self.prestream_complete or self.in_flight is not None or not self.state.connected
                or self.pilot_took_over or now_s - self.last_request_s < self.request_interval_s - _TIME_TOLERANCE_S):
            return None
        if self.state.mode != OFFBOARD:
            return Request.SET_OFFBOARD
        if not self.state.armed and not self.gave_up_arming:
            return Request.ARM
        return None

    def take_request(self, now_s):
        """The request due now, taken: none other is due until on_request_done(). None if none is due."""
        request = self.next_request(now_s)
        if request is not None:
            self.in_flight = request
        return request

    def on_request_done(self, now_s):
        """A request came back (or failed): the next one waits a full interval from now."""
        self.in_flight = None
        self.last_request_s = now_s
