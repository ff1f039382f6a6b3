"""Missions on the simulated PX4: the vehicle side of the MAVLink mission protocol.

`MissionTransfer` is the vehicle side of the mission protocol: upload (MISSION_COUNT,
then MISSION_REQUEST_INT per item, answered by MISSION_ITEM_INT or the legacy
MISSION_ITEM, then MISSION_ACK), download (MISSION_REQUEST_LIST, MISSION_COUNT, items on
request, INT or legacy), MISSION_CLEAR_ALL and MISSION_SET_CURRENT. Requests are
repeated when an item does not come, and the transfer is abandoned after a few tries.
Every mission type (mission, fence, rally) is stored; only the mission is flown.

Flying the items is the navigator's job (sim.mission_runner.MissionRunner).
"""

from collections import namedtuple

from offboard_py.dialect import mavlink

MISSION_TYPE_MISSION = mavlink.MAV_MISSION_TYPE_MISSION
MISSION_TYPES = (mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE, mavlink.MAV_MISSION_TYPE_RALLY)
MAX_ITEMS = 500
ITEM_TIMEOUT_S = 1.0
ITEM_RETRIES = 5

SUPPORTED_FRAMES = frozenset((
    mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_MISSION,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT))
# the legacy MISSION_ITEM has float coordinates: its frames have no _INT
_FLOAT_FRAMES = {mavlink.MAV_FRAME_GLOBAL_INT: mavlink.MAV_FRAME_GLOBAL,
                 mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                 mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT: mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT}

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


class MissionTransfer:
    """Vehicle side of the mission protocol for one link. `mav` builds messages, `send` sends them.

    `on_change(mission_type)` is called after every completed upload or clear.
    """

    def __init__(self, mav, send, on_change=lambda mission_type: None):
        self.mav, self.send = mav, send
        self.on_change = on_change
        self.items = {t: [] for t in MISSION_TYPES}
        self.current = 0
        self._upload = None  # dict(type, count, items, partner, next_seq, asked_s, tries, use_int)

    # -- helpers ----------------------------------------------------------------------------

    def _ack(self, partner, result, mission_type):
        self.send(self.mav.mission_ack_encode(partner[0], partner[1], result, mission_type))

    def _request_next(self, now_s):
        up = self._upload
        up['asked_s'] = now_s
        partner = up['partner']
        if up['use_int']:
            self.send(self.mav.mission_request_int_encode(partner[0], partner[1], up['next_seq'], up['type']))
        else:
            self.send(self.mav.mission_request_encode(partner[0], partner[1], up['next_seq'], up['type']))

    def mission(self):
        return self.items[MISSION_TYPE_MISSION]

    # -- protocol handlers ------------------------------------------------------------------

    def on_count(self, msg, now_s):
        partner, mtype = (msg.get_srcSystem(), msg.get_srcComponent()), msg.mission_type
        if mtype not in MISSION_TYPES:
            self._ack(partner, mavlink.MAV_MISSION_ERROR, mtype)
            return
        if msg.count > MAX_ITEMS:
            self._ack(partner, mavlink.MAV_MISSION_NO_SPACE, mtype)
            return
        if msg.count == 0:
            self._upload = None
            self._replace(mtype, [])
            self._ack(partner, mavlink.MAV_MISSION_ACCEPTED, mtype)
            return
        self._upload = dict(type=mtype, count=msg.count, items=[], partner=partner, next_seq=0,
                            asked_s=now_s, tries=0, use_int=True)
        self._request_next(now_s)

    def on_item(self, msg, now_s):
        up = self._upload
        if up is None or msg.mission_type != up['type']:
            return
        if msg.seq != up['next_seq']:
            self._request_next(now_s)  # out of order or repeated: ask again for the one we need
            return
        if msg.frame not in SUPPORTED_FRAMES:
            self._upload = None
            self._ack(up['partner'], mavlink.MAV_MISSION_UNSUPPORTED_FRAME, up['type'])
            return
        up['use_int'] = msg.get_type() == 'MISSION_ITEM_INT'  # answer in the client's dialect
        up['items'].append(item_from_message(msg))
        up['next_seq'] += 1
        up['tries'] = 0
        if up['next_seq'] < up['count']:
            self._request_next(now_s)
            return
        self._upload = None
        self._replace(up['type'], up['items'])
        self._ack(up['partner'], mavlink.MAV_MISSION_ACCEPTED, up['type'])

    def _replace(self, mission_type, items):
        self.items[mission_type] = list(items)
        if mission_type == MISSION_TYPE_MISSION:
            self.current = 0
        self.on_change(mission_type)

    def on_request_list(self, msg):
        mtype = msg.mission_type
        count = len(self.items.get(mtype, ()))
        self.send(self.mav.mission_count_encode(msg.get_srcSystem(), msg.get_srcComponent(), count, mtype))

    def on_request(self, msg):
        """MISSION_REQUEST_INT (answered with MISSION_ITEM_INT) or legacy MISSION_REQUEST."""
        items = self.items.get(msg.mission_type, [])
        partner = (msg.get_srcSystem(), msg.get_srcComponent())
        if not 0 <= msg.seq < len(items):
            self._ack(partner, mavlink.MAV_MISSION_INVALID_SEQUENCE, msg.mission_type)
            return
        it = items[msg.seq]
        current = int(msg.mission_type == MISSION_TYPE_MISSION and msg.seq == self.current)
        if msg.get_type() == 'MISSION_REQUEST_INT':
            scale = _int_scale(it.frame)
            x, y = int(round(it.x * scale)), int(round(it.y * scale))
            out = self.mav.mission_item_int_encode(partner[0], partner[1], msg.seq, it.frame, it.command, current,
                                                   it.autocontinue, it.param1, it.param2, it.param3, it.param4,
                                                   x, y, it.z, msg.mission_type)
        else:
            out = self.mav.mission_item_encode(partner[0], partner[1], msg.seq, _FLOAT_FRAMES.get(it.frame, it.frame),
                                               it.command, current, it.autocontinue, it.param1, it.param2,
                                               it.param3, it.param4, it.x, it.y, it.z, msg.mission_type)
        self.send(out)

    def on_clear_all(self, msg):
        mtype = msg.mission_type
        partner = (msg.get_srcSystem(), msg.get_srcComponent())
        if mtype == mavlink.MAV_MISSION_TYPE_ALL:
            for t in MISSION_TYPES:
                self._replace(t, [])
            self._ack(partner, mavlink.MAV_MISSION_ACCEPTED, mtype)
        elif mtype in MISSION_TYPES:
            self._replace(mtype, [])
            self._ack(partner, mavlink.MAV_MISSION_ACCEPTED, mtype)
        else:
            self._ack(partner, mavlink.MAV_MISSION_ERROR, mtype)

    def tick(self, now_s):
        """Repeat an unanswered request; give the upload up after ITEM_RETRIES tries."""
        up = self._upload
        if up is None or now_s - up['asked_s'] < ITEM_TIMEOUT_S:
            return
        up['tries'] += 1
        if up['tries'] > ITEM_RETRIES:
            self._upload = None
            self._ack(up['partner'], mavlink.MAV_MISSION_OPERATION_CANCELLED, up['type'])
        else:
            self._request_next(now_s)
