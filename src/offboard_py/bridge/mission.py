"""mavros waypoint plugin: ~mission/push, ~mission/pull, ~mission/clear, ~mission/waypoints, ~mission/reached.

Transfers use the MAVLink mission protocol with MISSION_ITEM_INT (answering a legacy
MISSION_REQUEST with MISSION_ITEM), one at a time, each step retried on timeout.
~mission/reached is latched, as mavros's is. ~mission/waypoints is latched and republished after every transfer (also when empty)
and when MISSION_CURRENT moves. 15 s after the connection the geofence, the rally points and
the mission are pulled, in that order, as mavros 1.21's geofence, rallypoint and waypoint plugins
do (px4_pluginlists.yaml loads all three; each pulls its list BOOTUP_TIME after the connection:
reference/px4-sitl-measured.md, "Recorded conversations": MISSION_REQUEST_LIST for mission_type 1, 2
and 0 at 15.0 s after the connection, within 2 ms). The geofence and rally items pulled are published
on ~geofence/waypoints and ~rallypoint/waypoints (latched WaypointLists, as mavros's geofence and
rallypoint plugins publish them after a pull; their pull/push/clear services are not offered).
A transfer runs in the service thread; the receive thread hands it the messages.
"""

import math
import queue
import threading

import rospy
from mavros_msgs.msg import Waypoint, WaypointList, WaypointReached
from mavros_msgs.srv import (WaypointClear, WaypointClearResponse, WaypointPull, WaypointPullResponse, WaypointPush,
                             WaypointPushResponse, WaypointSetCurrent, WaypointSetCurrentResponse)

from offboard_py.bridge import c_casts
from offboard_py.dialect import mavlink

# frames whose x/y are latitude/longitude: MISSION_ITEM_INT carries them in degrees * 1e7
GLOBAL_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                           mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                           mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT))
# MISSION_ITEM_INT's x/y scale as mavros's waypoint_encode_factor gives it: local frames metres * 1e4,
# any other frame (MISSION among them) 1
LOCAL_FRAMES = frozenset((mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_LOCAL_ENU, mavlink.MAV_FRAME_LOCAL_OFFSET_NED,
                          mavlink.MAV_FRAME_BODY_NED, mavlink.MAV_FRAME_BODY_OFFSET_NED, mavlink.MAV_FRAME_BODY_FRD,
                          mavlink.MAV_FRAME_LOCAL_FRD, mavlink.MAV_FRAME_LOCAL_FLU))


def encode_factor(frame):
    return 1e7 if frame in GLOBAL_FRAMES else 1e4 if frame in LOCAL_FRAMES else 1.0


STEP_TIMEOUT_S, STEP_RETRIES = 1.0, 3
PULL_AFTER_CONNECT_S = 15.0
# what is pulled after the connection, in mavros's order, with its log prefix and name
AUTO_PULLS = ((mavlink.MAV_MISSION_TYPE_FENCE, 'GF', 'geofence'), (mavlink.MAV_MISSION_TYPE_RALLY, 'RP', 'rally'),
              (mavlink.MAV_MISSION_TYPE_MISSION, 'WP', 'mission'))
LOG_PREFIXES = {mission_type: prefix for mission_type, prefix, _ in AUTO_PULLS}
LIST_NAMES = {mission_type: name for mission_type, _, name in AUTO_PULLS}
WAIT_SLICE_S = 0.05  # wall seconds between checks of a deadline on the bridge's clock
TRANSFER_MESSAGES = ('MISSION_COUNT', 'MISSION_ITEM_INT', 'MISSION_ITEM', 'MISSION_REQUEST_INT', 'MISSION_REQUEST',
                     'MISSION_ACK')


PROGRESS = object()  # returned by a step's accept(): the peer is moving on, restart the timeout


class TransferError(Exception):
    pass


def waypoint_from_item(item):
    wp = Waypoint()
    wp.frame, wp.command, wp.is_current, wp.autocontinue = item.frame, item.command, bool(item.current), \
        bool(item.autocontinue)
    wp.param1, wp.param2, wp.param3, wp.param4 = item.param1, item.param2, item.param3, item.param4
    if item.get_type() == 'MISSION_ITEM_INT':
        factor = encode_factor(item.frame)
        wp.x_lat, wp.y_long = item.x / factor, item.y / factor
    else:
        wp.x_lat, wp.y_long = item.x, item.y
    wp.z_alt = item.z
    return wp


class Mission:
    def __init__(self, bridge):
        self.bridge = bridge
        self.waypoints = []
        self.other_items = {}  # mission_type -> the items of a geofence or rally pull
        self.current_seq = 0
        self.transfer_lock = threading.Lock()
        self.inbox = None  # a Queue while a transfer runs
        self.inbox_type = mavlink.MAV_MISSION_TYPE_MISSION  # the mission_type of that transfer
        self.waypoints_pub = bridge.publisher('~mission/waypoints', WaypointList, queue_size=2, latch=True)
        self.other_pubs = {mission_type: bridge.publisher('~%s/waypoints' % topic, WaypointList, queue_size=2, latch=True)
                           for mission_type, topic in ((mavlink.MAV_MISSION_TYPE_FENCE, 'geofence'),
                                                       (mavlink.MAV_MISSION_TYPE_RALLY, 'rallypoint'))}
        # latched, as mavros's waypoint plugin advertises it: a late subscriber hears the last item reached
        self.reached_pub = bridge.publisher('~mission/reached', WaypointReached, latch=True)
        self.services = [bridge.service('~mission/set_current', WaypointSetCurrent, self._set_current)]
        # push, pull and clear for each list, as mavros's waypoint, geofence and rallypoint plugins (MissionBase
        # with its mission_type) offer them
        for mission_type, topic in ((mavlink.MAV_MISSION_TYPE_MISSION, 'mission'),
                                    (mavlink.MAV_MISSION_TYPE_FENCE, 'geofence'),
                                    (mavlink.MAV_MISSION_TYPE_RALLY, 'rallypoint')):
            self.services += [
                bridge.service('~%s/push' % topic, WaypointPush, lambda req, t=mission_type: self._push(req, t)),
                bridge.service('~%s/pull' % topic, WaypointPull, lambda req, t=mission_type: self._pull(req, t)),
                bridge.service('~%s/clear' % topic, WaypointClear, lambda req, t=mission_type: self._clear(req, t))]
        self.current_wanted = None  # (seq, Event) while ~mission/set_current waits for MISSION_CURRENT
        for name in TRANSFER_MESSAGES:
            bridge.on(name, self._to_transfer)
        bridge.on('MISSION_CURRENT', self._on_current)
        bridge.on('MISSION_ITEM_REACHED', self._on_reached)
        bridge.after_connect(PULL_AFTER_CONNECT_S, self._auto_pull)
        self._publish()

    # -- receive thread ----------------------------------------------------------------------

    def _to_transfer(self, msg):
        inbox = self.inbox
        # only the messages of the transfer's own mission_type
        mission_type = getattr(msg, 'mission_type', mavlink.MAV_MISSION_TYPE_MISSION)
        if inbox is not None and mission_type == self.inbox_type:
            inbox.put(msg)

    def _on_current(self, msg):
        wanted = self.current_wanted
        if wanted is not None and msg.seq == wanted[0]:
            wanted[1].set()
        if msg.seq != self.current_seq:
            self.current_seq = msg.seq
            for i, wp in enumerate(self.waypoints):
                wp.is_current = i == msg.seq
            self._publish()

    def _on_reached(self, msg):
        out = WaypointReached()
        out.header.stamp, out.wp_seq = self.bridge.now(), msg.seq
        rospy.loginfo('WP: reached #%d', msg.seq)
        self.reached_pub.publish(out)

    def _auto_pull(self):
        for mission_type, prefix, name in AUTO_PULLS:
            def attempt(mission_type=mission_type, prefix=prefix, name=name):
                try:
                    count = self._transfer(self._do_pull, mission_type, mission_type=mission_type)
                except TransferError as err:
                    return False, str(err)
                rospy.loginfo('%s: %s received: %d items', prefix, name, count)
                return True, None
            self.bridge.retry_while_connected('%s: %s pull after connection' % (prefix, name), attempt)

    def _publish(self):
        msg = WaypointList()
        msg.current_seq, msg.waypoints = self.current_seq, list(self.waypoints)
        self.waypoints_pub.publish(msg)

    # -- transfers (service threads) -------------------------------------------------------

    def _transfer(self, work, *args, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        """work(*args) with the transfer lock, handed the messages of that mission_type."""
        if not self.transfer_lock.acquire(blocking=False):
            raise TransferError('another mission transfer is in progress')
        self.inbox_type = mission_type
        self.inbox = queue.Queue()
        try:
            return work(*args)
        finally:
            self.inbox = None
            self.transfer_lock.release()

    def _wait(self, accept, resend, what):
        """Wait for a message that accept() returns a value for, resending on timeout.

        accept() returns None to ignore a message, PROGRESS when the peer moves on (the
        tries start again), or the result."""
        tries = 0
        while tries <= STEP_RETRIES:
            resend()
            tries += 1
            deadline = self.bridge.monotonic_s() + STEP_TIMEOUT_S
            while self.bridge.monotonic_s() < deadline and not self.bridge.is_shutdown():
                try:
                    msg = self.inbox.get(timeout=WAIT_SLICE_S)
                except queue.Empty:
                    continue
                value = accept(msg)
                if value is PROGRESS:
                    tries, deadline = 0, self.bridge.monotonic_s() + STEP_TIMEOUT_S
                elif value is not None:
                    return value
        raise TransferError('no answer to %s after %d tries' % (what, STEP_RETRIES + 1))

    def _do_pull(self, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        b = self.bridge
        target = (b.target_system, b.target_component)
        count = self._wait(lambda m: m.count if m.get_type() == 'MISSION_COUNT' else None,
                           lambda: b.send(b.mav.mission_request_list_encode(*target, mission_type)),
                           'MISSION_REQUEST_LIST')
        items = []
        for seq in range(count):
            items.append(self._wait(
                lambda m, seq=seq: m if m.get_type() in ('MISSION_ITEM_INT', 'MISSION_ITEM') and m.seq == seq
                else None,
                lambda seq=seq: b.send(b.mav.mission_request_int_encode(*target, seq, mission_type)),
                'MISSION_REQUEST_INT %d' % seq))
        b.send(b.mav.mission_ack_encode(*target, mavlink.MAV_MISSION_ACCEPTED, mission_type))
        if mission_type != mavlink.MAV_MISSION_TYPE_MISSION:
            self.other_items[mission_type] = items
            listed = WaypointList()  # current_seq 0: the geofence and rally plugins never move theirs
            listed.waypoints = [waypoint_from_item(item) for item in items]
            self.other_pubs[mission_type].publish(listed)
            return count
        self.waypoints = [waypoint_from_item(item) for item in items]
        self.current_seq = next((i for i, item in enumerate(items) if item.current), self.current_seq)
        self._publish()
        return count

    def _item(self, seq, wp, as_int, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        b = self.bridge
        target = (b.target_system, b.target_component)
        floats = {name: self._float32(seq, name, getattr(wp, name))
                  for name in ('param1', 'param2', 'param3', 'param4', 'z_alt')}
        params = [floats[name] for name in ('param1', 'param2', 'param3', 'param4')]
        if as_int:
            factor = encode_factor(wp.frame)
            x, y = (self._int32(seq, name, getattr(wp, name), factor) for name in ('x_lat', 'y_long'))
            return b.mav.mission_item_int_encode(*target, seq, wp.frame, wp.command, int(wp.is_current),
                                                 int(wp.autocontinue), *params, x, y, floats['z_alt'], mission_type)
        x, y = (self._float32(seq, name, getattr(wp, name)) for name in ('x_lat', 'y_long'))
        return b.mav.mission_item_encode(*target, seq, wp.frame, wp.command, int(wp.is_current),
                                         int(wp.autocontinue), *params, x, y, floats['z_alt'], mission_type)

    @staticmethod
    def _int32(seq, field, value, factor):
        """x/y of MISSION_ITEM_INT as mavros's int32_t(value * factor): truncated toward zero; NaN or out
        of range is x86's INT32_MIN, sent with a warning naming the field."""
        sent = c_casts.int32_from_double(value * factor)
        if sent == c_casts.INT32_MIN and value * factor != c_casts.INT32_MIN:
            rospy.logwarn('WP: item %d: %s %r does not fit MISSION_ITEM_INT (* %g): sent as %d, as mavros '
                          'casts it', seq, field, value, factor, sent)
        return sent

    @staticmethod
    def _float32(seq, field, value):
        """A float field as mavros's double -> float: infinity beyond the largest float, with a warning."""
        sent = c_casts.float32_from_double(value)
        if math.isinf(sent) and math.isfinite(value):
            rospy.logwarn('WP: item %d: %s %r is beyond a float: sent as %r, as mavros casts it', seq, field, value,
                          sent)
        return sent

    def _do_push(self, waypoints, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        b = self.bridge
        target = (b.target_system, b.target_component)
        sent = set()

        def accept(msg):
            kind = msg.get_type()
            if kind in ('MISSION_REQUEST_INT', 'MISSION_REQUEST') and 0 <= msg.seq < len(waypoints):
                b.send(self._item(msg.seq, waypoints[msg.seq], kind == 'MISSION_REQUEST_INT', mission_type))
                sent.add(msg.seq)
                return PROGRESS
            if kind == 'MISSION_ACK':
                return msg.type
            return None
        # MISSION_COUNT is repeated only until the FCU asks for an item; then it drives the transfer
        result = self._wait(accept, lambda: None if sent else b.send(b.mav.mission_count_encode(
            *target, len(waypoints), mission_type)), 'MISSION_COUNT / items')
        if result != mavlink.MAV_MISSION_ACCEPTED:
            raise TransferError('FCU refused the %s: MAV_MISSION_RESULT %d' % (LIST_NAMES[mission_type], result))
        self._stored(mission_type, list(waypoints))
        return len(sent)

    def _stored(self, mission_type, waypoints):
        """What the FCU now holds, published as mavros does after a push or clear."""
        if mission_type != mavlink.MAV_MISSION_TYPE_MISSION:
            listed = WaypointList()
            listed.waypoints = waypoints
            self.other_pubs[mission_type].publish(listed)
            return
        self.waypoints = waypoints
        self.current_seq = 0
        self._publish()

    def _do_clear(self, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        b = self.bridge
        target = (b.target_system, b.target_component)
        result = self._wait(lambda m: m.type if m.get_type() == 'MISSION_ACK' else None,
                            lambda: b.send(b.mav.mission_clear_all_encode(*target, mission_type)),
                            'MISSION_CLEAR_ALL')
        if result != mavlink.MAV_MISSION_ACCEPTED:
            raise TransferError('FCU refused to clear the %s: MAV_MISSION_RESULT %d'
                                % (LIST_NAMES[mission_type], result))
        self._stored(mission_type, [])

    def _push(self, req, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        prefix = LOG_PREFIXES[mission_type]
        if req.start_index != 0:
            rospy.logerr('%s: partial push (start_index %d) is not supported by PX4', prefix, req.start_index)
            return WaypointPushResponse(success=False, wp_transfered=0)
        try:
            if not req.waypoints:
                self._transfer(self._do_clear, mission_type, mission_type=mission_type)
                return WaypointPushResponse(success=True, wp_transfered=0)
            count = self._transfer(self._do_push, list(req.waypoints), mission_type, mission_type=mission_type)
            return WaypointPushResponse(success=True, wp_transfered=count)
        except TransferError as err:
            rospy.logerr('%s: push failed: %s', prefix, err)
            return WaypointPushResponse(success=False, wp_transfered=0)

    def _pull(self, _req, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        try:
            count = self._transfer(self._do_pull, mission_type, mission_type=mission_type)
            return WaypointPullResponse(success=True, wp_received=count)
        except TransferError as err:
            rospy.logerr('%s: pull failed: %s', LOG_PREFIXES[mission_type], err)
            return WaypointPullResponse(success=False, wp_received=0)

    def _clear(self, _req, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        try:
            self._transfer(self._do_clear, mission_type, mission_type=mission_type)
            return WaypointClearResponse(success=True)
        except TransferError as err:
            rospy.logerr('%s: clear failed: %s', LOG_PREFIXES[mission_type], err)
            return WaypointClearResponse(success=False)

    def _set_current(self, req):
        """MISSION_SET_CURRENT, answered by the FCU's MISSION_CURRENT with that seq (tries as a transfer step)."""
        b = self.bridge
        done = threading.Event()
        self.current_wanted = (req.wp_seq, done)
        try:
            for _ in range(STEP_RETRIES + 1):
                b.send(b.mav.mission_set_current_encode(b.target_system, b.target_component, req.wp_seq))
                if b.wait(done, STEP_TIMEOUT_S):
                    return WaypointSetCurrentResponse(success=True)
        finally:
            self.current_wanted = None
        rospy.logerr('WP: set current #%d: no MISSION_CURRENT with it after %d tries', req.wp_seq, STEP_RETRIES + 1)
        return WaypointSetCurrentResponse(success=False)
