"""mavros param: ~param/pull, ~param/get, ~param/set.

The list is pulled from the FCU (PARAM_REQUEST_LIST; missing indices re-read one by
one) 10 s after the connection, as mavros does, and on ~param/pull. ~param/get answers
from that list. ~param/set sends PARAM_SET, with PX4's bytewise INT32 encoding
(offboard_py.param_codec), and waits for the PARAM_VALUE echo: success when the FCU
echoes the value asked for. Integer parameters travel in value.integer, floats in value.real.

As mavros, the values are mirrored into the ROS parameter server under ~param/<ID> (an int for an
integer parameter, a float for a REAL32 one) once ~param/pull has run and after each ~param/set, but
not after the pull that follows the connection; PX4's _HASH_CHECK is never mirrored. ~param/push
reads ~param back, skipping the ids mavros never pushes (PUSH_EXCLUDED).

Better than mavros, which answers success=false until its pull is done (PX4's own
posctl test sets COM_RCL_EXCEPT right after start and gives up): a get or set of a
parameter not pulled yet waits for a pull under way, else reads that one parameter from
the FCU (PARAM_REQUEST_READ by name). A parameter the FCU does not know either (no
answer to READ_RETRIES reads) gets success=false and an error naming it.
"""

import collections
import math
import threading

import rospy
from mavros_msgs.msg import ParamValue
from mavros_msgs.srv import (ParamGet, ParamGetResponse, ParamPull, ParamPullResponse, ParamPush, ParamPushResponse,
                             ParamSet, ParamSetRequest, ParamSetResponse)

from offboard_py import param_codec
from offboard_py.bridge import c_casts

PULL_AFTER_CONNECT_S = 10.0       # mavros waits for the FCU to boot before pulling
LIST_TIMEOUT_S = 30.0
SET_TIMEOUT_S, SET_RETRIES = 1.0, 3  # mavros sends an unechoed PARAM_SET again SET_RETRIES times
READ_TIMEOUT_S, READ_RETRIES = 1.0, 3  # reads of a parameter by name in all, as mavros re-reads a missing index
PARAM_ID_MAX = 16                 # MAVLink's param_id is char[16]
QUIET_S = 1.0                     # no PARAM_VALUE for this long: re-read what is missing
INDEX_UNKNOWN = 0xFFFF            # PARAM_VALUE.param_index when the FCU gives none (MAVLink's -1 as uint16)
NOT_MIRRORED = '_HASH_CHECK'      # PX4's hash of the whole list: mavros keeps it out of ~param
# Counters and calibration results that mavros's param/push never writes back (its check_exclude_param_id);
# most are ArduPilot's, kept so that a ~param loaded from an ArduPilot dump pushes as with mavros.
PUSH_EXCLUDED = frozenset(('SYSID_SW_MREV', 'SYS_NUM_RESETS', 'ARSPD_OFFSET', 'GND_ABS_PRESS', 'GND_ABS_PRESS2',
                           'GND_ABS_PRESS3', 'STAT_BOOTCNT', 'STAT_FLTTIME', 'STAT_RESET', 'STAT_RUNTIME', 'GND_TEMP',
                           'CMD_TOTAL', 'CMD_INDEX', 'LOG_LASTFILE', 'FENCE_TOTAL', 'FORMAT_VERSION'))


class Param:
    def __init__(self, bridge):
        self.bridge = bridge
        self.lock = threading.Condition()
        self.values = {}        # id -> (value, type)
        self.arrivals = collections.Counter()  # id -> PARAM_VALUEs seen, to spot an echo
        self.count = None
        self.indices = set()
        self.last_value_s = 0.0
        self.pull_lock = threading.Lock()
        self.services = [bridge.service('~param/pull', ParamPull, self._pull),
                         bridge.service('~param/get', ParamGet, self._get),
                         bridge.service('~param/set', ParamSet, self._set),
                         bridge.service('~param/push', ParamPush, self._push)]
        bridge.on('PARAM_VALUE', self._on_value)
        bridge.after_connect(PULL_AFTER_CONNECT_S, self._auto_pull)

    def _auto_pull(self):
        def attempt():
            if self.complete():
                return True, None
            count = self.pull(force=False)
            if self.complete():
                rospy.loginfo('PR: parameters received: %d', count)
                return True, None
            return False, '%d of %s parameters received' % (count, self.count if self.count is not None else 'an unknown number of')
        self.bridge.retry_while_connected('PR: parameter pull after connection', attempt)

    def _on_value(self, msg):
        with self.lock:
            self.values[msg.param_id] = (param_codec.decode(msg.param_type, msg.param_value), msg.param_type)
            self.arrivals[msg.param_id] += 1
            self.count = msg.param_count
            if msg.param_index != INDEX_UNKNOWN:
                self.indices.add(msg.param_index)
            self.last_value_s = self.bridge.monotonic_s()
            self.lock.notify_all()

    def complete(self):
        return self.count is not None and len(self.indices) >= self.count

    def pull(self, force):
        """Pull the list; return the number of parameters received."""
        b = self.bridge
        with self.pull_lock:
            if self.complete() and not force:
                return len(self.values)
            with self.lock:
                self.indices.clear()
                self.count = None
                self.last_value_s = self.bridge.monotonic_s()
            b.send(b.mav.param_request_list_encode(b.target_system, b.target_component))
            deadline = b.monotonic_s() + LIST_TIMEOUT_S
            with self.lock:
                while not self.complete() and self.bridge.monotonic_s() < deadline and not b.is_shutdown():
                    self.lock.wait(0.2)
                    if self.count is not None and self.bridge.monotonic_s() - self.last_value_s > QUIET_S:
                        missing = sorted(set(range(self.count)) - self.indices)[:50]
                        for index in missing:
                            b.send(b.mav.param_request_read_encode(b.target_system, b.target_component, b'', index))
                        self.last_value_s = self.bridge.monotonic_s()
                return len(self.indices)

    def _pull(self, req):
        received = self.pull(req.force_pull)
        with self.lock:
            pulled = sorted(self.values)
        for param_id in pulled:  # as mavros, whether the pull is complete or not
            self._mirror(param_id)
        return ParamPullResponse(success=self.complete(), param_received=received)

    def _mirror(self, param_id):
        """Put the FCU's value of a parameter into ~param/<ID>, so that `rosparam get` and a later
        ~param/push see it, as mavros's rosparam_set_allowed: an int or a float by the parameter's type."""
        with self.lock:
            value, param_type = self.values[param_id]
        if param_id == NOT_MIRRORED:
            rospy.loginfo('PR: PX4 parameter %s ignored: 0x%08x', param_id, int(value) & 0xFFFFFFFF)
            return
        self.bridge.set_param('~param/' + param_id,
                              int(value) if param_codec.is_integer(param_type) else float(value))

    @staticmethod
    def _value_msg(value, param_type):
        msg = ParamValue()
        if param_codec.is_integer(param_type):
            msg.integer = int(value)
        else:
            msg.real = float(value)
        return msg

    def _entry(self, param_id):
        """(value, type) of a parameter: from the pulled list, else after the pull under way,
        else read from the FCU now; None when the FCU does not know it (or is not there)."""
        with self.lock:
            entry = self.values.get(param_id)
        if entry is not None:
            return entry
        if self.pull_lock.locked() and self.pull_lock.acquire(timeout=LIST_TIMEOUT_S):
            self.pull_lock.release()  # the pull under way is over: it may have brought it
            with self.lock:
                entry = self.values.get(param_id)
            if entry is not None:
                return entry
        return self._read(param_id)

    def _read(self, param_id):
        b = self.bridge
        if not b.connected or b.is_shutdown():
            return None
        for _ in range(READ_RETRIES):
            with self.lock:
                before = self.arrivals[param_id]
            b.send(b.mav.param_request_read_encode(b.target_system, b.target_component, param_id.encode(), -1))
            deadline = b.monotonic_s() + READ_TIMEOUT_S
            with self.lock:
                while self.bridge.monotonic_s() < deadline and not b.is_shutdown():
                    if self.arrivals[param_id] != before:
                        return self.values[param_id]
                    self.lock.wait(0.05)
        return None

    @staticmethod
    def _bad_id(param_id):
        if not param_id or len(param_id) > PARAM_ID_MAX or not param_id.isascii():
            return 'parameter id %r: 1 to %d ASCII characters' % (param_id, PARAM_ID_MAX)
        return None

    def _get(self, req):
        problem = self._bad_id(req.param_id)
        entry = None if problem else self._entry(req.param_id)
        if entry is None:
            rospy.logerr('PR: %s', problem or 'unknown parameter %s: the FCU does not answer for it (%d pulled)'
                         % (req.param_id, len(self.values)))
            return ParamGetResponse(success=False)
        return ParamGetResponse(success=True, value=self._value_msg(*entry))

    def _set(self, req):
        b = self.bridge
        problem = self._bad_id(req.param_id)
        entry = None if problem else self._entry(req.param_id)
        if entry is None:
            rospy.logerr('PR: %s', problem or 'Unknown parameter to set: %s (the FCU does not answer for it)'
                         % req.param_id)
            return ParamSetResponse(success=False)
        param_type = entry[1]
        wanted = req.value.integer if req.value.integer != 0 else req.value.real
        if not math.isfinite(wanted):
            rospy.logerr('PR: %s: value %r is not a finite number', req.param_id, wanted)
            return ParamSetResponse(success=False, value=self._value_msg(*entry))
        wanted = self._as_sent(req.param_id, param_type, wanted, 'value.integer' if req.value.integer else 'value.real')
        wire = param_codec.encode(param_type, wanted)
        echo = None
        for _ in range(SET_RETRIES + 1):
            with self.lock:
                before = self.arrivals[req.param_id]
            b.send(b.mav.param_set_encode(b.target_system, b.target_component, req.param_id.encode(), wire,
                                          param_type))
            echo = self._echo(req.param_id, before, b.monotonic_s() + SET_TIMEOUT_S)
            if echo is not None:
                break
        self._mirror(req.param_id)  # what the FCU last said, echo or not, as mavros's set_cb writes it
        if echo is None:
            rospy.logerr('PR: %s: no PARAM_VALUE echo after %d tries', req.param_id, SET_RETRIES + 1)
            return ParamSetResponse(success=False, value=self._value_msg(*entry))
        value, vtype = echo
        same = value == wanted or (not param_codec.is_integer(vtype) and abs(value - wanted) < 1e-6 *
                                   max(1.0, abs(wanted)))
        if not same:  # mavros answers success for any echo (send_param_set_and_wait); the value says the rest
            rospy.logwarn('PR: %s: the FCU kept %r, not %r', req.param_id, value, wanted)
        return ParamSetResponse(success=True, value=self._value_msg(value, vtype))

    def _echo(self, param_id, before, deadline_s):
        """(value, type) of the first PARAM_VALUE of `param_id` after the `before`th, or None by the deadline."""
        b = self.bridge
        with self.lock:
            while b.monotonic_s() < deadline_s and not b.is_shutdown():
                if self.arrivals[param_id] != before:
                    return self.values[param_id]
                self.lock.wait(0.05)
        return None

    @staticmethod
    def _as_sent(param_id, param_type, value, field):
        """The value mavros's casts put on the wire: an integer's low 32 bits (static_cast<int>), a
        real into an integer parameter as int32_t(double), into a float one as a float (inf
        beyond); logged when that is not the value asked for."""
        if isinstance(value, int):
            sent = c_casts.int32_from_int(value)
            sent = sent if param_codec.is_integer(param_type) else float(sent)
        elif param_codec.is_integer(param_type):
            sent = c_casts.int32_from_double(value)
        else:
            sent = c_casts.float32_from_double(value)
        float_rounding = isinstance(value, float) and not param_codec.is_integer(param_type) and math.isfinite(sent)
        if sent != value and not float_rounding:
            rospy.logwarn('PR: %s: %s %r does not fit the parameter: sent as %r, as mavros casts it',
                          param_id, field, value, sent)
        return sent

    def _push(self, _req):
        """mavros's param/push (push_cb): every ROS parameter under ~param that the FCU has is set on it
        again, changed or not, except the ids mavros never pushes; an unknown one is warned of;
        `param_transfered` counts the sets the FCU echoed, and the answer is success whatever they did."""
        wanted = self.bridge.get_param('~param', {})
        if not isinstance(wanted, dict):
            rospy.logerr('PR: ~param is not a dictionary of parameters: %r', wanted)
            return ParamPushResponse(success=True, param_transfered=0)
        transferred = 0
        for name, value in sorted(wanted.items()):
            if name in PUSH_EXCLUDED:
                continue
            if self._entry(name) is None:
                rospy.logwarn('PR: Unknown rosparam: %s', name)
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                rospy.logerr('PR: ~param/%s: %r is not a number: not set', name, value)
                continue
            req = ParamSetRequest(param_id=name)
            if isinstance(value, int):
                req.value.integer = value
            else:
                req.value.real = value
            if self._set(req).success:
                transferred += 1
        return ParamPushResponse(success=True, param_transfered=transferred)
