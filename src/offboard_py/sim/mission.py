"""Missions on the simulated PX4: the MAVLink mission protocol and the flying of the items.

`MissionTransfer` is the vehicle side of the mission protocol: upload (MISSION_COUNT,
then MISSION_REQUEST_INT per item, answered by MISSION_ITEM_INT or the legacy
MISSION_ITEM, then MISSION_ACK), download (MISSION_REQUEST_LIST, MISSION_COUNT, items on
request, INT or legacy), MISSION_CLEAR_ALL and MISSION_SET_CURRENT. Requests are
repeated when an item does not come, and the transfer is abandoned after a few tries.
Every mission type (mission, fence, rally) is stored; only the mission is flown.

`MissionRunner` turns the current item into a setpoint: NAV_TAKEOFF, NAV_WAYPOINT (with
its acceptance radius and hold time), NAV_LOITER_TIME, NAV_LOITER_UNLIM, NAV_LAND and
NAV_RETURN_TO_LAUNCH; other items (DO_*) are passed over. It reports reached items.
"""

from collections import namedtuple

from offboard_py.sim import vehicle as vm

MISSION_TYPE_MISSION = 0
MISSION_TYPES = (0, 1, 2)  # mission, fence, rally
# MAV_MISSION_RESULT
MISSION_ACCEPTED, MISSION_ERROR, MISSION_UNSUPPORTED_FRAME, MISSION_NO_SPACE = 0, 1, 2, 4
MISSION_INVALID_SEQUENCE, MISSION_DENIED, MISSION_OPERATION_CANCELLED = 13, 14, 15
MAX_ITEMS = 500
ITEM_TIMEOUT_S = 1.0
ITEM_RETRIES = 5

# MAV_CMD used in missions
NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TIME, NAV_RETURN_TO_LAUNCH = 16, 17, 19, 20
NAV_LAND, NAV_TAKEOFF = 21, 22
# MAV_FRAME
FRAME_GLOBAL, FRAME_LOCAL_NED, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT = 0, 1, 2, 3
FRAME_GLOBAL_INT, FRAME_GLOBAL_RELATIVE_ALT_INT = 5, 6
FRAME_GLOBAL_TERRAIN_ALT, FRAME_GLOBAL_TERRAIN_ALT_INT = 10, 11
SUPPORTED_FRAMES = {FRAME_GLOBAL, FRAME_LOCAL_NED, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL_INT,
                    FRAME_GLOBAL_RELATIVE_ALT_INT, FRAME_GLOBAL_TERRAIN_ALT, FRAME_GLOBAL_TERRAIN_ALT_INT}
_INT_FRAMES = {FRAME_GLOBAL_INT: FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT_INT: FRAME_GLOBAL_RELATIVE_ALT,
               FRAME_GLOBAL_TERRAIN_ALT_INT: FRAME_GLOBAL_TERRAIN_ALT}

Item = namedtuple('Item', 'frame command autocontinue param1 param2 param3 param4 x y z')
Item.__doc__ = 'A stored item: x/y are degrees (global frames) or metres (local), z metres.'


def _int_scale(frame):
    """MISSION_ITEM_INT x/y units: degrees * 1e7 (global), metres * 1e4 (local), raw (MISSION)."""
    return {FRAME_LOCAL_NED: 1e4, FRAME_MISSION: 1.0}.get(frame, 1e7)


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
            self._ack(partner, MISSION_ERROR, mtype)
            return
        if msg.count > MAX_ITEMS:
            self._ack(partner, MISSION_NO_SPACE, mtype)
            return
        if msg.count == 0:
            self._upload = None
            self._replace(mtype, [])
            self._ack(partner, MISSION_ACCEPTED, mtype)
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
            self._ack(up['partner'], MISSION_UNSUPPORTED_FRAME, up['type'])
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
        self._ack(up['partner'], MISSION_ACCEPTED, up['type'])

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
            self._ack(partner, MISSION_INVALID_SEQUENCE, msg.mission_type)
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
            out = self.mav.mission_item_encode(partner[0], partner[1], msg.seq, _INT_FRAMES.get(it.frame, it.frame),
                                               it.command, current, it.autocontinue, it.param1, it.param2,
                                               it.param3, it.param4, it.x, it.y, it.z, msg.mission_type)
        self.send(out)

    def on_clear_all(self, msg):
        mtype = msg.mission_type
        partner = (msg.get_srcSystem(), msg.get_srcComponent())
        if mtype == 255:  # MAV_MISSION_TYPE_ALL
            for t in MISSION_TYPES:
                self._replace(t, [])
            self._ack(partner, MISSION_ACCEPTED, mtype)
        elif mtype in MISSION_TYPES:
            self._replace(mtype, [])
            self._ack(partner, MISSION_ACCEPTED, mtype)
        else:
            self._ack(partner, MISSION_ERROR, mtype)

    def tick(self, now_s):
        """Repeat an unanswered request; give the upload up after ITEM_RETRIES tries."""
        up = self._upload
        if up is None or now_s - up['asked_s'] < ITEM_TIMEOUT_S:
            return
        up['tries'] += 1
        if up['tries'] > ITEM_RETRIES:
            self._upload = None
            self._ack(up['partner'], MISSION_OPERATION_CANCELLED, up['type'])
        else:
            self._request_next(now_s)


class MissionRunner:
    """Flies mission items. Pure: the commander feeds it the vehicle and the time."""

    def __init__(self, params, frame):
        self.params, self.frame = params, frame
        self.items = []
        self.seq = 0
        self.reached = []        # seq numbers reached since the last take_reached()
        self.finished = False
        self._arrived_s = None   # when the current item's position was reached
        self._hold_point = None
        self._takeoff_xy = None

    def load(self, items, seq=0):
        self.items, self.seq, self.finished = list(items), seq, False
        self._arrived_s = self._hold_point = self._takeoff_xy = None

    def set_current(self, seq):
        if 0 <= seq < len(self.items):
            self.seq, self.finished, self._arrived_s = seq, False, None
            return True
        return False

    def take_reached(self):
        reached, self.reached = self.reached, []
        return reached

    def _target(self, it, vehicle):
        """Local NED target of a positional item (NaN where the item leaves it open)."""
        if it.frame == FRAME_LOCAL_NED:
            return (it.x, it.y, it.z)
        if it.frame == FRAME_MISSION:
            return tuple(vehicle.position)
        if it.x == 0.0 and it.y == 0.0:  # no position given: here
            north, east = vehicle.position[0], vehicle.position[1]
        else:
            north, east, _ = self.frame.to_local(it.x, it.y, self.frame.alt0)
        if it.frame in (FRAME_GLOBAL, FRAME_GLOBAL_INT):
            down = self.frame.alt0 - it.z
        else:  # relative to home (terrain frames are treated as relative: flat ground)
            down = -it.z
        return (north, east, down)

    def _advance(self, now_s):
        self.reached.append(self.seq)
        self._arrived_s = None
        if self.seq + 1 < len(self.items):
            self.seq += 1
        else:
            self.finished = True

    def setpoint(self, vehicle, now_s):
        """The setpoint for now; reached items are recorded in `reached`."""
        p = self.params
        for _ in range(len(self.items)):  # pass over DO_* items in one go
            if self.finished or not self.items:
                break
            it = self.items[self.seq]
            if it.command in (NAV_TAKEOFF, NAV_WAYPOINT, NAV_LOITER_TIME, NAV_LOITER_UNLIM,
                              NAV_LAND, NAV_RETURN_TO_LAUNCH):
                break
            self._advance(now_s)
        if self.finished or not self.items:
            if self._hold_point is None:
                self._hold_point = tuple(vehicle.position)
            return vm.hold(self._hold_point, vehicle.yaw)
        self._hold_point = None
        it = self.items[self.seq]
        pos = vehicle.position
        if it.command == NAV_TAKEOFF:
            target = self._target(it, vehicle)
            if self._takeoff_xy is None:
                self._takeoff_xy = (pos[0], pos[1])
            north, east = self._takeoff_xy
            down = target[2] if target[2] < -0.5 else -p['MIS_TAKEOFF_ALT']
            if abs(pos[2] - down) <= p['NAV_MC_ALT_RAD'] * 0.5:
                self._takeoff_xy = None
                self._advance(now_s)
            return vm.setpoint(position=(north, east, down), yaw=vehicle.yaw, z_up_max=p['MPC_TKO_SPEED'])
        if it.command == NAV_RETURN_TO_LAUNCH:
            target = (0.0, 0.0, min(pos[2], 0.0))
            if _dist_xy(pos, target) > 1.0:
                return vm.setpoint(position=(0.0, 0.0, pos[2]), yaw=vehicle.yaw, xy_speed_max=p['MPC_XY_CRUISE'])
            return self._land_at(target, vehicle, now_s)
        target = self._target(it, vehicle)
        if it.command == NAV_LAND:
            if _dist_xy(pos, target) > 1.0:
                return vm.setpoint(position=(target[0], target[1], pos[2]), yaw=vehicle.yaw,
                                   xy_speed_max=p['MPC_XY_CRUISE'])
            return self._land_at(target, vehicle, now_s)
        radius = it.param2 if it.command == NAV_WAYPOINT and it.param2 > 0 else p['NAV_ACC_RAD']
        if self._arrived_s is None and (_dist_xy(pos, target) <= radius
                                        and abs(pos[2] - target[2]) <= p['NAV_MC_ALT_RAD']):
            self._arrived_s = now_s
        if self._arrived_s is not None:
            hold_s = it.param1 if it.command in (NAV_WAYPOINT, NAV_LOITER_TIME) else None
            if hold_s is not None and now_s - self._arrived_s >= max(hold_s, 0.0):
                self._advance(now_s)
        return vm.setpoint(position=target, yaw=vehicle.yaw, xy_speed_max=p['MPC_XY_CRUISE'])

    def _land_at(self, target, vehicle, now_s):
        if vehicle.landed:
            self._advance(now_s)
            self.finished = True
            return vm.hold((target[0], target[1], 0.0), vehicle.yaw)
        return land_setpoint(self.params, (target[0], target[1]), vehicle)


def _dist_xy(a, b):
    return ((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2) ** 0.5


def land_setpoint(params, xy, vehicle):
    """Descend over xy at PX4's landing speeds: MPC_Z_VEL_MAX_DN high up, MPC_LAND_SPEED below ALT2."""
    height = vehicle.height()
    fast, slow = params['MPC_Z_VEL_MAX_DN'], params['MPC_LAND_SPEED']
    alt1, alt2 = params['MPC_LAND_ALT1'], params['MPC_LAND_ALT2']
    if height >= alt1:
        speed = fast
    elif height <= alt2 or alt1 <= alt2:
        speed = slow
    else:
        speed = slow + (fast - slow) * (height - alt2) / (alt1 - alt2)
    return vm.setpoint(position=(xy[0], xy[1], vm.NAN), velocity=(vm.NAN, vm.NAN, speed), yaw=vehicle.yaw)
