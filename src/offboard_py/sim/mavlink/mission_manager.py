"""Missions on the simulated PX4: the vehicle side of the MAVLink mission protocol.

`MissionManager` is the vehicle side of the mission protocol as PX4 main's MavlinkMissionManager
(src/modules/mavlink/mavlink_mission.cpp at the recorded 02e73e3b6f) runs it: one state (idle,
receiving a list, sending one) with one partner (system and component), upload (MISSION_COUNT,
then MISSION_REQUEST_INT per item, answered by MISSION_ITEM_INT or the legacy MISSION_ITEM, then
MISSION_ACK), download (MISSION_REQUEST_LIST, MISSION_COUNT, items on request, INT or legacy,
the partner's MISSION_ACK), MISSION_CLEAR_ALL. An upload's request is repeated every 250 ms
until the next item comes; any transfer is dropped, with the text "Operation timeout" and no
MISSION_ACK, 5 s after the partner last spoke. Items are checked as PX4 parses them: global
frames (the _INT ones only in MISSION_ITEM_INT) for the navigation commands, MAV_FRAME_MISSION
for the others, anything else refused. Every mission type (mission, fence, rally) is stored;
only the mission is flown.

Flying the items is the navigator's job (sim.mission_runner.MissionRunner).
"""

import math
from collections import namedtuple

from offboard_py.dialect import mavlink

MISSION_TYPE_MISSION = mavlink.MAV_MISSION_TYPE_MISSION
MISSION_TYPES = (mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE, mavlink.MAV_MISSION_TYPE_RALLY)
# items a type holds: PX4 SITL's CONFIG_NUM_MISSION_ITMES_SUPPORTED (boards/px4/sitl/default.px4board), and
# dataman's DM_KEY_FENCE_POINTS_MAX and DM_KEY_SAFE_POINTS_MAX
MAX_COUNT = {mavlink.MAV_MISSION_TYPE_MISSION: 10000, mavlink.MAV_MISSION_TYPE_FENCE: 64,
             mavlink.MAV_MISSION_TYPE_RALLY: 32}
RETRY_S = 0.25             # MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT: an upload's request again
PROTOCOL_TIMEOUT_S = 5.0   # MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT: the transfer dropped
MISSION_PLANNER = mavlink.MAV_COMP_ID_MISSIONPLANNER  # a target component PX4's mission manager also takes

# MAV_CMD_CONDITION_GATE (4501) and MAV_CMD_DO_SET_ACTUATOR (187) of common.xml, which pymavlink 2.4.49 lacks
MAV_CMD_CONDITION_GATE = getattr(mavlink, 'MAV_CMD_CONDITION_GATE', 4501)
MAV_CMD_DO_SET_ACTUATOR = getattr(mavlink, 'MAV_CMD_DO_SET_ACTUATOR', 187)
# parse_mavlink_mission_item: the commands taken with coordinates (global frames) ...
GLOBAL_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT))
INT_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT))
GLOBAL_COMMANDS = frozenset((
    mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_UNLIM, mavlink.MAV_CMD_NAV_LOITER_TIME,
    mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LOITER_TO_ALT,
    mavlink.MAV_CMD_NAV_ROI, mavlink.MAV_CMD_DO_SET_ROI, mavlink.MAV_CMD_DO_SET_ROI_LOCATION,
    mavlink.MAV_CMD_NAV_VTOL_TAKEOFF, mavlink.MAV_CMD_NAV_VTOL_LAND, MAV_CMD_CONDITION_GATE,
    mavlink.MAV_CMD_NAV_FENCE_RETURN_POINT, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, mavlink.MAV_CMD_NAV_RALLY_POINT,
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE))
# ... and without (MAV_FRAME_MISSION)
MISSION_FRAME_COMMANDS = frozenset((
    mavlink.MAV_CMD_DO_JUMP, mavlink.MAV_CMD_NAV_ROI, mavlink.MAV_CMD_DO_SET_ROI, mavlink.MAV_CMD_DO_WINCH,
    mavlink.MAV_CMD_DO_GRIPPER, mavlink.MAV_CMD_DO_CHANGE_SPEED, mavlink.MAV_CMD_DO_SET_HOME,
    mavlink.MAV_CMD_DO_LAND_START, mavlink.MAV_CMD_DO_TRIGGER_CONTROL, mavlink.MAV_CMD_DO_DIGICAM_CONTROL,
    mavlink.MAV_CMD_DO_MOUNT_CONFIGURE, mavlink.MAV_CMD_DO_MOUNT_CONTROL, mavlink.MAV_CMD_IMAGE_START_CAPTURE,
    mavlink.MAV_CMD_IMAGE_STOP_CAPTURE, mavlink.MAV_CMD_VIDEO_START_CAPTURE, mavlink.MAV_CMD_VIDEO_STOP_CAPTURE,
    mavlink.MAV_CMD_DO_CONTROL_VIDEO, mavlink.MAV_CMD_DO_SET_CAM_TRIGG_DIST, mavlink.MAV_CMD_OBLIQUE_SURVEY,
    mavlink.MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL, mavlink.MAV_CMD_SET_CAMERA_MODE, mavlink.MAV_CMD_SET_CAMERA_SOURCE,
    mavlink.MAV_CMD_DO_VTOL_TRANSITION, mavlink.MAV_CMD_NAV_DELAY, mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH,
    mavlink.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET, mavlink.MAV_CMD_DO_SET_ROI_NONE, mavlink.MAV_CMD_CONDITION_DELAY,
    mavlink.MAV_CMD_CONDITION_DISTANCE, MAV_CMD_DO_SET_ACTUATOR, mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE,
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM))
# what a mission (not a fence or rally list) may not hold (PX4's check against wrong clients)
NOT_IN_A_MISSION = frozenset((
    mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
    mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
    mavlink.MAV_CMD_NAV_RALLY_POINT))
# the legacy MISSION_ITEM has float coordinates: its frames have no _INT
_FLOAT_FRAMES = {mavlink.MAV_FRAME_GLOBAL_INT: mavlink.MAV_FRAME_GLOBAL,
                 mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                 mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT: mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT}

# format_mavlink_mission_item: PX4 keeps a positional item as its own mission_item_s (relative or absolute
# altitude, and the fields its command has) and sends it back in the frame of the download's message,
# MISSION_ITEM_INT (_INT frames) or MISSION_ITEM, with only those fields; yaw (param4) as wrap_2pi(radians(x)) in
# degrees. Per command: the params sent back, as (param index, how it was kept); the others are 0
_KEPT, _FLAG, _YAW = 'kept', 'flag', 'yaw'
DOWNLOADED_PARAMS = {
    mavlink.MAV_CMD_NAV_WAYPOINT: ((1, _KEPT), (2, _KEPT), (4, _YAW)),
    mavlink.MAV_CMD_NAV_LOITER_UNLIM: ((3, _KEPT), (4, _YAW)),
    mavlink.MAV_CMD_NAV_LOITER_TIME: ((1, _KEPT), (2, _FLAG), (3, _KEPT), (4, _FLAG)),
    mavlink.MAV_CMD_NAV_LAND: ((2, _KEPT), (4, _YAW)),
    mavlink.MAV_CMD_NAV_TAKEOFF: ((4, _YAW),),
    mavlink.MAV_CMD_NAV_LOITER_TO_ALT: ((1, _FLAG), (2, _KEPT), (4, _FLAG)),
    mavlink.MAV_CMD_NAV_VTOL_TAKEOFF: ((4, _YAW),),
    mavlink.MAV_CMD_NAV_VTOL_LAND: ((4, _YAW),),
}
RELATIVE_FRAMES = frozenset((mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT))


def _yaw_degrees(degrees):
    """wrap_2pi(radians(x)) back in degrees, as float32 keeps it (NaN stays NaN)."""
    if degrees != degrees:
        return degrees
    return math.degrees(math.radians(degrees) % (2.0 * math.pi))


def downloaded(it, int_mode):
    """(frame, param1..param4) of a stored mission item as PX4 sends it back: MAV_FRAME_MISSION items as they
    came, positional ones in GLOBAL_RELATIVE_ALT(_INT) or GLOBAL(_INT) by their altitude and the download's
    message, with the fields PX4 keeps for the command."""
    params = (it.param1, it.param2, it.param3, it.param4)
    if it.frame not in GLOBAL_FRAMES | INT_FRAMES or it.command not in DOWNLOADED_PARAMS:
        return it.frame, params
    relative = it.frame in RELATIVE_FRAMES
    if int_mode:
        frame = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT if relative else mavlink.MAV_FRAME_GLOBAL_INT
    else:
        frame = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT if relative else mavlink.MAV_FRAME_GLOBAL
    out = [0.0, 0.0, 0.0, 0.0]
    for index, kept in DOWNLOADED_PARAMS[it.command]:
        value = params[index - 1]
        out[index - 1] = _yaw_degrees(value) if kept == _YAW else float(value > 0) if kept == _FLAG else value
    return frame, tuple(out)


Item = namedtuple('Item', 'frame command autocontinue param1 param2 param3 param4 x y z')
Item.__doc__ = 'A stored item: x/y are degrees (global frames) or metres (local), z metres.'


def _int_scale(frame):
    """MISSION_ITEM_INT x/y units: degrees * 1e7 (global), metres * 1e4 (local), raw (MISSION)."""
    return {mavlink.MAV_FRAME_LOCAL_NED: 1e4, mavlink.MAV_FRAME_MISSION: 1.0}.get(frame, 1e7)


def item_from_message(msg):
    """An Item from MISSION_ITEM_INT (scaled integers) or MISSION_ITEM (floats)."""
    scale = _int_scale(msg.frame) if msg.get_type() == 'MISSION_ITEM_INT' else 1.0
    x, y = float(msg.x) / scale, float(msg.y) / scale
    return Item(msg.frame, msg.command, msg.autocontinue, msg.param1, msg.param2, msg.param3, msg.param4,
                x, y, float(msg.z))


class ReachedRepeats:
    """MISSION_ITEM_REACHED said again, as each link's MavlinkMissionManager::send() does: with MISSION_CURRENT at
    its 1 Hz (_slow_rate_limiter), the last reached seq another REACHED_REPEATS times while a mission is loaded;
    a new mission forgets it (_last_reached = -1)."""

    REACHED_REPEATS = 10

    def __init__(self):
        self.seq, self.sent = -1, 0

    def reached(self, seq):
        self.seq, self.sent = seq, 0

    def forget(self):
        self.seq = -1

    def due(self, mission_count):
        """The seq to say again with this MISSION_CURRENT, or None."""
        if mission_count <= 0 or self.seq < 0 or self.sent >= self.REACHED_REPEATS:
            return None
        self.sent += 1
        return self.seq


class MissionManager:
    """Vehicle side of the mission protocol, PX4's state machine (module docstring).

    `mav` builds messages; `say(text)` is a critical text for the ground station; `on_change(mission_type)`
    is called after every completed upload or clear. Each handler on_*(msg, now_s, link) is given the link
    the message came from, where its answers go (a transfer's requests go to the link it began on).
    """

    IDLE, GETLIST, SENDLIST = 'idle', 'getlist', 'sendlist'

    def __init__(self, mav, system_id, say=lambda text: None, on_change=lambda mission_type: None):
        self.mav, self.system_id, self.say, self.on_change = mav, system_id, say, on_change
        self.items = {t: [] for t in MISSION_TYPES}
        self.current = 0
        self.state = self.IDLE
        self.mission_type = mavlink.MAV_MISSION_TYPE_MISSION
        self.partner = (0, 0)
        self.partner_link = None
        self.transfer_seq = 0      # the next item to receive or send
        self.transfer_count = 0
        self.received = []         # an upload's items so far
        self.int_mode = True       # MISSION_REQUEST_INT / MISSION_ITEM_INT, else the legacy pair
        self.last_sent_s = None    # an upload's last request
        self.last_recv_s = None    # the partner's last message of the transfer

    def for_me(self, msg):
        """PX4's CHECK_SYSID_COMPID_MISSION: its own system id (not 0) and component 1, 0 or the mission planner's."""
        return msg.target_system == self.system_id and msg.target_component in (0, 1, MISSION_PLANNER)

    def mission(self):
        return self.items[MISSION_TYPE_MISSION]

    # -- sending ----------------------------------------------------------------------------

    def _send(self, msg, link):
        link.send(msg)

    def _ack(self, partner, result, link):
        """MISSION_ACK on `link` with the type of the transfer under way (or last), as PX4's send_mission_ack."""
        self._send(self.mav.mission_ack_encode(partner[0], partner[1], result, self.mission_type), link)

    def _refuse(self, partner, text, link):
        """PX4's text for the ground station and MISSION_ACK ERROR to `partner` on `link`."""
        self.say(text)
        self._ack(partner, mavlink.MAV_MISSION_ERROR, link)

    def _request(self, now_s):
        self.last_sent_s = now_s
        encode = self.mav.mission_request_int_encode if self.int_mode else self.mav.mission_request_encode
        self._send(encode(self.partner[0], self.partner[1], self.transfer_seq, self.mission_type), self.partner_link)

    def _idle(self):
        self.state = self.IDLE

    def _begin(self, msg, state, mission_type, now_s, link):
        self.state, self.mission_type = state, mission_type
        self.partner = (msg.get_srcSystem(), msg.get_srcComponent())
        self.partner_link = link
        self.transfer_seq, self.last_recv_s, self.last_sent_s = 0, now_s, None

    def _from_partner(self, msg):
        return (msg.get_srcSystem(), msg.get_srcComponent()) == self.partner

    # -- upload -----------------------------------------------------------------------------

    def on_count(self, msg, now_s, link):
        partner, mtype = (msg.get_srcSystem(), msg.get_srcComponent()), msg.mission_type
        if self.state == self.GETLIST:
            self.last_recv_s = now_s
            if partner != self.partner:
                self._ack(partner, mavlink.MAV_MISSION_ERROR, link)  # another client while receiving
            elif self.transfer_seq == 0:
                self._request(now_s)  # our first request was lost: ask again
            else:
                self._refuse(self.partner, 'WPM: REJ. CMD: Busy', link)
            return
        if self.state != self.IDLE:
            self._refuse(partner, 'WPM: IGN MISSION_COUNT: Busy', link)
            return
        self.mission_type, self.partner, self.last_recv_s = mtype, partner, now_s
        if msg.count > MAX_COUNT.get(mtype, 0):
            self._ack(partner, mavlink.MAV_MISSION_NO_SPACE, link)
            return
        if msg.count == 0:
            if mtype in MISSION_TYPES:
                self._replace(mtype, [])
            self._ack(partner, mavlink.MAV_MISSION_ACCEPTED, link)
            return
        self._begin(msg, self.GETLIST, mtype, now_s, link)
        self.transfer_count, self.received = msg.count, []
        self._request(now_s)

    def on_item(self, msg, now_s, link):
        if not self._from_partner(msg):
            self.say('REJ. MIS ITEM: partner id mismatch')
            return
        self.int_mode = msg.get_type() == 'MISSION_ITEM_INT'  # answer in the client's dialect
        if msg.mission_type != self.mission_type:
            self._ack(self.partner, mavlink.MAV_MISSION_ERROR, link)
            return
        if self.state == self.IDLE:
            if self.transfer_seq == msg.seq + 1:
                self._ack(self.partner, mavlink.MAV_MISSION_ACCEPTED, link)  # the last item again: our ACK was lost
            else:
                self._refuse(self.partner, 'IGN MISSION_ITEM: No transfer', link)
            return
        if self.state != self.GETLIST:
            self._refuse(self.partner, 'IGN MISSION_ITEM: Busy', link)
            return
        self.last_recv_s = now_s
        if msg.seq != self.transfer_seq:
            return  # not the one asked for: PX4 ignores it and asks again on its retry
        result = self._check(msg)
        if result == mavlink.MAV_MISSION_ACCEPTED and self.mission_type == MISSION_TYPE_MISSION \
                and msg.command in NOT_IN_A_MISSION:
            result = mavlink.MAV_MISSION_ERROR
        if result != mavlink.MAV_MISSION_ACCEPTED:
            self.say('IGN MISSION_ITEM: Invalid item')
            self._ack(self.partner, result, link)
            self._idle()
            return
        self.received.append(item_from_message(msg))
        self.transfer_seq = msg.seq + 1
        if self.transfer_seq < self.transfer_count:
            self._request(now_s)
            return
        self._idle()
        self._replace(self.mission_type, self.received)
        self._ack(self.partner, mavlink.MAV_MISSION_ACCEPTED, self.partner_link)

    def _check(self, msg):
        """PX4's parse_mavlink_mission_item: the frame, then the command."""
        if msg.frame in GLOBAL_FRAMES or (self.int_mode and msg.frame in INT_FRAMES):
            return mavlink.MAV_MISSION_ACCEPTED if msg.command in GLOBAL_COMMANDS else mavlink.MAV_MISSION_UNSUPPORTED
        if msg.frame == mavlink.MAV_FRAME_MISSION:
            return mavlink.MAV_MISSION_ACCEPTED if msg.command in MISSION_FRAME_COMMANDS \
                else mavlink.MAV_MISSION_UNSUPPORTED
        return mavlink.MAV_MISSION_UNSUPPORTED_FRAME

    def _replace(self, mission_type, items):
        self.items[mission_type] = list(items)
        if mission_type == MISSION_TYPE_MISSION:
            self.current = 0
        self.on_change(mission_type)

    # -- download ---------------------------------------------------------------------------

    def on_request_list(self, msg, now_s, link):
        partner, mtype = (msg.get_srcSystem(), msg.get_srcComponent()), msg.mission_type
        if self.state == self.SENDLIST and self.transfer_seq == self.transfer_count:
            self._idle()  # all sent and the ACK never came: a new list may start
        if self.state == self.IDLE or (self.state == self.SENDLIST and mtype == self.mission_type
                                       and partner == self.partner):
            self._begin(msg, self.SENDLIST, mtype, now_s, link)
            self.transfer_count = len(self.items.get(mtype, ()))
            self._send(self.mav.mission_count_encode(partner[0], partner[1], self.transfer_count, mtype), link)
        else:
            self.say('Mission download request ignored, already active')

    def on_request(self, msg, now_s, link):
        """MISSION_REQUEST_INT (answered with MISSION_ITEM_INT) or legacy MISSION_REQUEST, in a download."""
        self.int_mode = msg.get_type() == 'MISSION_REQUEST_INT'
        if not self._from_partner(msg):
            self.say('WPM: REJ. CMD: partner id mismatch')
            return
        if self.state == self.IDLE:
            return  # PX4 ignores it silently (some clients ask out of turn)
        if self.state != self.SENDLIST:
            self.say('WPM: REJ. CMD: Busy')
            return
        if msg.mission_type != self.mission_type:
            return
        self.last_recv_s = now_s
        items = self.items.get(msg.mission_type, [])
        if msg.seq == self.transfer_seq and self.transfer_seq < self.transfer_count:
            self.transfer_seq += 1
            expected = True
        else:
            expected = msg.seq == self.transfer_seq - 1  # the last one again
        if not expected or msg.seq >= len(items):  # or the list changed under the download
            self._idle()
            self._refuse(self.partner, 'WPM: REJ. CMD: Req. WP was unexpected', link)
            return
        self._send(self._item_message(msg, items[msg.seq]), link)

    def _item_message(self, msg, it):
        partner = (msg.get_srcSystem(), msg.get_srcComponent())
        current = int(msg.mission_type == MISSION_TYPE_MISSION and msg.seq == self.current)
        frame, params = downloaded(it, self.int_mode)
        if self.int_mode:
            scale = _int_scale(it.frame)
            x, y = int(round(it.x * scale)), int(round(it.y * scale))
            return self.mav.mission_item_int_encode(partner[0], partner[1], msg.seq, frame, it.command, current,
                                                    it.autocontinue, *params, x, y, it.z, msg.mission_type)
        return self.mav.mission_item_encode(partner[0], partner[1], msg.seq, _FLOAT_FRAMES.get(frame, frame),
                                            it.command, current, it.autocontinue, *params, it.x, it.y, it.z,
                                            msg.mission_type)

    def on_ack(self, msg, now_s, link):
        """The partner's MISSION_ACK: a download is over; an upload cancelled by the client ends (an upload's
        request again goes to the link the upload began on, not `link`)."""
        if not self._from_partner(msg):
            self.say('REJ. WP CMD: partner id mismatch')
            return
        if self.state == self.SENDLIST and msg.mission_type == self.mission_type:
            self.last_recv_s = now_s
            self._idle()
        elif self.state == self.GETLIST:
            if msg.type == mavlink.MAV_MISSION_UNSUPPORTED:
                self.int_mode = not self.int_mode  # the client speaks the other dialect: ask in it
                self._request(now_s)
            elif msg.type == mavlink.MAV_MISSION_OPERATION_CANCELLED:
                self._idle()

    # -- clear ------------------------------------------------------------------------------

    def on_clear_all(self, msg, now_s, link):
        partner, mtype = (msg.get_srcSystem(), msg.get_srcComponent()), msg.mission_type
        if self.state != self.IDLE:
            self.say('WPM: IGN CLEAR CMD: Busy')
            return
        self.last_recv_s, self.mission_type = now_s, mtype
        if mtype == mavlink.MAV_MISSION_TYPE_ALL:
            for t in MISSION_TYPES:
                self._replace(t, [])
        elif mtype in MISSION_TYPES:
            self._replace(mtype, [])
        self._ack(partner, mavlink.MAV_MISSION_ACCEPTED, link)

    # -- time -------------------------------------------------------------------------------

    def tick(self, now_s):
        """An upload's request again RETRY_S after the last; any transfer dropped PROTOCOL_TIMEOUT_S after the
        partner last spoke, with a text and no MISSION_ACK, as PX4's MavlinkMissionManager::send()."""
        if self.state == self.GETLIST and self.last_sent_s is not None and now_s - self.last_sent_s > RETRY_S:
            self._request(now_s)
        elif self.state != self.IDLE and self.last_recv_s is not None and \
                now_s - self.last_recv_s > PROTOCOL_TIMEOUT_S:
            self.say('Operation timeout')
            self._idle()
