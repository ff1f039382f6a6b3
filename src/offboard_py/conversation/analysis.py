"""One recording summed up as named figures, the form compare.py holds two recordings to.

A figure is a value with its kind, which says how two of them are compared (compare.py):
  'rate'   messages per second; `slack` is the count quantisation of its phase (1.5 messages over
           the phase's length), so that a short phase's rate is not judged by one message;
  'time'   seconds: an event's time after its anchor (phases.anchors: connected, first setpoint,
           last setpoint, whichever came last before it) or a delay between a request and its answer;
  'count'  how many;
  'value'  a result, a sequence of states, a set of field values: equal or not.
Keys are paths: 'rate/ros/armed hover/SYSTEM_TIME', 'command/ros/MAV_CMD_COMPONENT_ARM_DISARM/delay',
'mission/ros/type 1/at', 'param/ros/list/at', 'mode/fcu/sequence', 'timesync/ros/answered',
'seq/fcu/comp 1/gaps per 1000'. The accepted differences of a test name them (fnmatch patterns).
"""

import collections
import statistics

from offboard_py.conversation import phases as phases_mod
from offboard_py.dialect import mavlink

Figure = collections.namedtuple('Figure', 'value kind slack')
Figure.__new__.__defaults__ = (0.0,)

COMMAND_ANSWER_WINDOW_S = 5.0   # an ACK later than this is not counted as an answer (mavros's ACK timeout: 5 s)
MISSION_ANSWER_WINDOW_S = 2.0
RATE_SLACK_MESSAGES = 1.5
# commands the tutorial's node sends (through the ROS side's services): timed from the first setpoint
NODE_COMMANDS = frozenset(('SET_MODE', 'MAV_CMD_COMPONENT_ARM_DISARM'))


def command_name(number):
    entry = mavlink.enums['MAV_CMD'].get(number)
    return entry.name if entry is not None else 'MAV_CMD_%d' % number


def mission_type_name(number):
    return 'type %d' % number


def other(direction):
    return 'ros' if direction == 'fcu' else 'fcu'


class Summary:
    """The figures of one recording (`figures`: {key: Figure}) and what the PNG draws:
    `phases`, `anchors`, `events` [(t, dir, text)], `rates` {(dir, phase, type): rate}."""

    def __init__(self, messages, name=''):
        self.name = name
        self.messages = messages
        self.phases = phases_mod.phases(messages)
        self.anchors = phases_mod.anchors(messages)
        self.figures = collections.OrderedDict()
        self.events = []
        self.rates = {}
        self._phase_by_index = [phases_mod.phase_of(m.t, self.phases) for m in messages]
        self._phase_figures()
        self._rates()
        self._commands()
        self._missions()
        self._params()
        self._modes()
        self._timesync()
        self._sequence()
        self._heartbeat_content()
        self.events.sort()

    def put(self, key, value, kind, slack=0.0):
        self.figures[key] = Figure(value, kind, slack)

    def after_anchor(self, t):
        """(anchor name, seconds after it) for the last anchor at or before t."""
        best = ('start', t - self.anchors['start'])
        for name in ('connected', 'first setpoint', 'last setpoint'):
            at = self.anchors[name]
            if at is not None and at <= t:
                best = (name, t - at)
        return best

    def put_time(self, key, t, anchor=None):
        """The time t after `anchor` (phases.anchors' name), or after the last anchor before t."""
        if anchor is None or self.anchors.get(anchor) is None:
            anchor, seconds = self.after_anchor(t)
        else:
            seconds = t - self.anchors[anchor]
        self.put('%s/after %s' % (key, anchor), round(seconds, 4), 'time')

    def command_anchor(self, direction, name, t):
        """What a command is timed from: the node's from the first setpoint, the ROS side's own from the
        connection, the FCU's from the last setpoint once the setpoints have ended (its failsafe)."""
        if direction == 'ros':
            return 'first setpoint' if name in NODE_COMMANDS else 'connected'
        last = self.anchors['last setpoint']
        return 'last setpoint' if last is not None and t >= last else 'connected'

    # -- the figures --------------------------------------------------------------------------------

    def _phase_figures(self):
        self.put('phase/sequence', ' > '.join(p.name for p in self.phases), 'value')
        for p in self.phases:
            self.put('phase/%s/duration' % p.name, round(p.duration, 3), 'time')
        for name in ('connected', 'first setpoint', 'last setpoint'):
            if self.anchors[name] is not None:
                self.events.append((self.anchors[name], 'fcu' if name == 'connected' else 'ros', name))

    def _rates(self):
        counts = collections.Counter()
        for m, phase in zip(self.messages, self._phase_by_index):
            counts[(m.dir, phase, m.type)] += 1
        lengths = {p.name: p.duration for p in self.phases}
        for (direction, phase, kind), n in sorted(counts.items()):
            length = lengths[phase]
            if length <= 0:
                continue
            self.rates[(direction, phase, kind)] = n / length
            self.put('rate/%s/%s/%s' % (direction, phase, kind), round(n / length, 3), 'rate',
                     RATE_SLACK_MESSAGES / length)
        # a type one side sends in a phase and the other does not shows as a figure absent on one side;
        # when each type starts after the connection (slack: one period of its overall rate, a timer's phase)
        connected = self.anchors['connected']
        if connected is None:
            return
        # only the types that start after it: the FCU's streams run before anyone listens
        firsts, totals, before = {}, collections.Counter(), set()
        for m in self.messages:
            if m.t < connected:
                before.add((m.dir, m.type))
            elif (m.dir, m.type) not in before:
                firsts.setdefault((m.dir, m.type), m.t)
                totals[(m.dir, m.type)] += 1
        length = max(1e-9, self.anchors['end'] - connected)
        for (direction, kind), t in sorted(firsts.items()):
            rate = totals[(direction, kind)] / length
            self.put('first/%s/%s/after connected' % (direction, kind), round(t - connected, 4), 'time',
                     1.0 / rate if rate >= 0.5 else 0.0)

    def _commands(self):
        sends = []  # (t, dir, name, ack command number)
        acks = []   # (t, dir, command, result)
        for m in self.messages:
            if m.type in ('COMMAND_LONG', 'COMMAND_INT'):
                sends.append((m.t, m.dir, command_name(m.get('command')), m.get('command')))
            elif m.type == 'SET_MODE':
                sends.append((m.t, m.dir, 'SET_MODE', mavlink.MAV_CMD_DO_SET_MODE))
            elif m.type == 'COMMAND_ACK':
                acks.append((m.t, m.dir, m.get('command'), m.get('result')))
        by_name = collections.OrderedDict()
        for i, (t, direction, name, number) in enumerate(sends):
            # the answers to this send: ACKs of its command from the other side, before the same
            # command is sent again (a retry's answers are the retry's) and within the window
            later = [s[0] for s in sends[i + 1:] if s[1] == direction and s[3] == number]
            until = min([t + COMMAND_ANSWER_WINDOW_S] + later)
            answers = [(at - t, result) for at, adir, command, result in acks
                       if adir == other(direction) and command == number and t <= at < until]
            by_name.setdefault((direction, name), []).append((t, answers))
            self.events.append((t, direction, name.replace('MAV_CMD_', '')))
        for (direction, name), items in by_name.items():
            key = 'command/%s/%s' % (direction, name)
            self.put(key + '/sent', len(items), 'count')
            self.put_time(key + '/first', items[0][0], self.command_anchor(direction, name, items[0][0]))
            self.put(key + '/answers', sum(len(a) for _, a in items), 'count')
            results = sorted(set(r for _, a in items for _, r in a))
            self.put(key + '/results', ','.join(str(r) for r in results) or 'none', 'value')
            delays = [a[0][0] for _, a in items if a]
            if delays:
                self.put(key + '/delay', round(statistics.median(delays), 4), 'time')

    def _missions(self):
        requests = collections.OrderedDict()  # (dir, type) -> [t]
        for i, m in enumerate(self.messages):
            if m.type != 'MISSION_REQUEST_LIST':
                continue
            mtype = m.get('mission_type', 0)
            requests.setdefault((m.dir, mtype), []).append(m.t)
            self.events.append((m.t, m.dir, 'MISSION_REQUEST_LIST %d' % mtype))
        for (direction, mtype), times in requests.items():
            key = 'mission/%s/%s' % (direction, mission_type_name(mtype))
            self.put(key + '/requests', len(times), 'count')
            self.put_time(key + '/first', times[0], 'connected')
            answers = [m for m in self.messages if m.type == 'MISSION_COUNT' and m.dir == other(direction)
                       and m.get('mission_type', 0) == mtype and times[0] <= m.t]
            if answers:
                self.put(key + '/count answered', answers[0].get('count'), 'value')
                self.put(key + '/answer delay', round(answers[0].t - times[0], 4), 'time')
            acks = [m for m in self.messages if m.type == 'MISSION_ACK' and m.dir == direction
                    and m.get('mission_type', 0) == mtype]
            self.put(key + '/acks', len(acks), 'count')
        # the order of the pulls by type (mavros: geofence, rally, mission)
        for direction in ('ros', 'fcu'):
            order = [mtype for (d, mtype), _ in sorted(requests.items(), key=lambda kv: kv[1][0]) if d == direction]
            if order:
                self.put('mission/%s/order' % direction, ','.join(str(t) for t in order), 'value')

    def _params(self):
        for direction in ('ros', 'fcu'):
            lists = [m.t for m in self.messages if m.dir == direction and m.type == 'PARAM_REQUEST_LIST']
            reads = [m.t for m in self.messages if m.dir == direction and m.type == 'PARAM_REQUEST_READ']
            sets = [m.t for m in self.messages if m.dir == direction and m.type == 'PARAM_SET']
            if not (lists or reads or sets):
                continue
            key = 'param/%s' % direction
            self.put(key + '/list requests', len(lists), 'count')
            self.put(key + '/reads', len(reads), 'count')
            self.put(key + '/sets', len(sets), 'count')
            if lists:
                self.put_time(key + '/list', lists[0], 'connected')
                self.events.append((lists[0], direction, 'PARAM_REQUEST_LIST'))
                values = [m for m in self.messages if m.dir == other(direction) and m.type == 'PARAM_VALUE'
                          and m.t >= lists[0]]
                if values:
                    self.put(key + '/values answered', len(values), 'count')
                    self.put(key + '/first value delay', round(values[0].t - lists[0], 4), 'time')
                    self.put(key + '/pull length', round(values[-1].t - lists[0], 3), 'time')
                    counts = set(m.get('param_count') for m in values)
                    self.put(key + '/param_count', ','.join(str(c) for c in sorted(counts)), 'value')

    def _modes(self):
        states, status, landed = [], [], []
        for m in self.messages:
            if phases_mod.is_fcu_heartbeat(m):
                mode, armed = phases_mod.fcu_state(m)
                state = '%s %s' % (mode, 'armed' if armed else 'disarmed')
                if not states or states[-1][1] != state:
                    states.append((m.t, state))
                if not status or status[-1][1] != m.get('system_status'):
                    status.append((m.t, m.get('system_status')))
            elif m.dir == 'fcu' and m.type == 'EXTENDED_SYS_STATE':
                if not landed or landed[-1][1] != m.get('landed_state'):
                    landed.append((m.t, m.get('landed_state')))
        self.put('mode/fcu/sequence', ' > '.join(s for _, s in states), 'value')
        self.put('system_status/fcu/sequence', ' > '.join(str(s) for _, s in status), 'value')
        self.put('landed_state/fcu/sequence', ' > '.join(str(s) for _, s in landed), 'value')
        seen = collections.Counter()
        for t, state in states[1:]:
            seen[state] += 1
            self.put_time('mode/fcu/%s #%d' % (state, seen[state]), t)
            self.events.append((t, 'fcu', state))
        seen.clear()
        for t, value in landed[1:]:
            seen[value] += 1
            self.put_time('landed_state/fcu/%s #%d' % (value, seen[value]), t)
            self.events.append((t, 'fcu', 'landed_state %s' % value))
        # from the node's request to the FCU's HEARTBEAT that shows it done
        for name, done in (('SET_MODE', lambda s: s.startswith('OFFBOARD')), ('arming', lambda s: s.endswith(' armed'))):
            if name == 'SET_MODE':
                asks = [m.t for m in self.messages if m.dir == 'ros' and m.type == 'SET_MODE']
            else:
                asks = [m.t for m in self.messages if m.dir == 'ros' and m.type == 'COMMAND_LONG'
                        and m.get('command') == mavlink.MAV_CMD_COMPONENT_ARM_DISARM and m.get('param1') == 1.0]
            if asks:
                shown = [t for t, s in states if t >= asks[0] and done(s)]
                if shown:
                    self.put('mode/fcu/%s shown after' % name, round(shown[0] - asks[0], 4), 'time')

    def _timesync(self):
        requests = {'fcu': {}, 'ros': {}}  # dir -> {ts1: t}
        for m in self.messages:
            if m.type == 'TIMESYNC' and m.get('tc1') == 0:
                requests[m.dir][m.get('ts1')] = m.t
        connected = self.anchors['connected'] or self.anchors['start']
        length = max(1e-9, self.anchors['end'] - connected)
        for direction in ('ros', 'fcu'):
            asked = requests[direction]
            answers = [(m.t - asked[m.get('ts1')]) for m in self.messages
                       if m.type == 'TIMESYNC' and m.dir == other(direction) and m.get('tc1') != 0
                       and m.get('ts1') in asked]
            n = sum(1 for t in asked.values() if t >= connected)
            if not asked:
                continue
            self.put('timesync/%s/requests' % direction, round(n / length, 3), 'rate', RATE_SLACK_MESSAGES / length)
            self.put('timesync/%s/answered by %s' % (direction, other(direction)),
                     round(len(answers) / len(asked), 3), 'rate', 0.05)
            if answers:
                self.put('timesync/%s/answer delay' % direction, round(statistics.median(answers), 4), 'time')

    def _sequence(self):
        last, gaps, lost, count = {}, collections.Counter(), collections.Counter(), collections.Counter()
        for m in self.messages:
            sender = (m.dir, m.sys, m.comp)
            count[sender] += 1
            if sender in last:
                step = (m.seq - last[sender]) % 256
                if step != 1:
                    gaps[sender] += 1
                    lost[sender] += (step - 1) % 256
            last[sender] = m.seq
        for sender, n in sorted(count.items()):
            key = 'seq/%s/comp %d' % (sender[0], sender[2])  # not the system id: it is the SITL instance's
            self.put(key + '/messages', n, 'count')
            self.put(key + '/gaps per 1000', round(1000.0 * gaps[sender] / n, 2), 'rate', 1000.0 * 2 / n)

    def _heartbeat_content(self):
        for direction in ('ros', 'fcu'):
            seen = set()
            for m in self.messages:
                if m.dir == direction and m.type == 'HEARTBEAT':
                    seen.add((m.comp, m.get('type'), m.get('autopilot'), m.get('mavlink_version')))
            if seen:
                self.put('heartbeat/%s/comp,type,autopilot,version' % direction,
                         ' '.join('%s,%s,%s,%s' % s for s in sorted(seen)), 'value')
        ros = sorted(set((m.get('base_mode'), m.get('custom_mode'), m.get('system_status')) for m in self.messages
                         if m.dir == 'ros' and m.type == 'HEARTBEAT'))
        if ros:
            self.put('heartbeat/ros/base_mode,custom_mode,system_status', ' '.join('%s,%s,%s' % s for s in ros),
                     'value')
