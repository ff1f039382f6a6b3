"""The phases of a takeoff flight, derived from its conversation alone.

The flight of the references (reference/conversations/README.md): connect, stream setpoints,
OFFBOARD, arm, hover; the node stops (the setpoints end), PX4's offboard-loss failsafe (AUTO.RTL)
lands and disarms. Boundaries, each the first message that shows it:
  connecting   the FCU's first message (its boot, as the references begin) .. the ROS side's first setpoint
  pre-stream   the first setpoint .. the FCU's first HEARTBEAT in OFFBOARD
  OFFBOARD     .. the FCU's first HEARTBEAT armed
  armed hover  .. the ROS side's last setpoint
  failsafe     .. touchdown: the first of the FCU's EXTENDED_SYS_STATE on the ground and its HEARTBEAT
                  disarmed after that
  landed       .. the recording's end
A phase whose start never comes is missing (a flight that never armed has no armed hover), and
the ones after it start where it would have ended. The anchors that timed events are measured from:
'connected' (the FCU's first HEARTBEAT once the ROS side has spoken: when mavros connects),
'first setpoint' and 'last setpoint'.
"""

import collections

from offboard_py import px4_modes
from offboard_py.dialect import mavlink

PHASES = ('connecting', 'pre-stream', 'OFFBOARD', 'armed hover', 'failsafe', 'landed')
SETPOINT_TYPES = frozenset(('SET_POSITION_TARGET_LOCAL_NED', 'SET_POSITION_TARGET_GLOBAL_INT', 'SET_ATTITUDE_TARGET'))


class Phase(collections.namedtuple('Phase', 'name start end')):
    @property
    def duration(self):
        return self.end - self.start


def fcu_state(msg):
    """(mode string, armed) of an FCU HEARTBEAT."""
    armed = bool(msg.get('base_mode', 0) & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    custom = msg.get('custom_mode', 0) if msg.get('base_mode', 0) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED else 0
    return px4_modes.decode(custom), armed


def is_fcu_heartbeat(m):
    return m.dir == 'fcu' and m.type == 'HEARTBEAT' and m.comp == mavlink.MAV_COMP_ID_AUTOPILOT1


def anchors(messages):
    """{'start', 'end', 'connected', 'first setpoint', 'last setpoint'}: times (None when absent)."""
    # the flight starts with the FCU's first message (the references begin at PX4's boot, mavros already
    # up): what a ROS side sends before there is an FCU is not part of it
    first_fcu = next((m.t for m in messages if m.dir == 'fcu'), None)
    start = first_fcu if first_fcu is not None else (messages[0].t if messages else 0.0)
    out = {'start': start, 'end': messages[-1].t if messages else 0.0,
           'connected': None, 'first setpoint': None, 'last setpoint': None}
    ros_spoke = False
    for m in messages:
        if m.dir == 'ros':
            ros_spoke = True
            if m.type in SETPOINT_TYPES:
                if out['first setpoint'] is None:
                    out['first setpoint'] = m.t
                out['last setpoint'] = m.t
        elif ros_spoke and out['connected'] is None and is_fcu_heartbeat(m):
            out['connected'] = m.t
    return out


def boundaries(messages):
    """{phase name: start time or None} for PHASES[1:] (connecting starts the recording)."""
    a = anchors(messages)
    starts = {'pre-stream': a['first setpoint'], 'OFFBOARD': None, 'armed hover': None, 'failsafe': None,
              'landed': None}
    if starts['pre-stream'] is None:
        return starts
    ever_armed = False
    for m in messages:
        if m.t < starts['pre-stream']:
            continue
        if is_fcu_heartbeat(m):
            mode, armed = fcu_state(m)
            if starts['OFFBOARD'] is None and mode == 'OFFBOARD':
                starts['OFFBOARD'] = m.t
            if starts['OFFBOARD'] is not None and starts['armed hover'] is None and armed:
                starts['armed hover'] = m.t
            ever_armed = ever_armed or armed
            if starts['armed hover'] is not None and m.t > a['last setpoint'] and not armed and \
                    starts['landed'] is None:
                starts['landed'] = m.t
        elif (m.dir == 'fcu' and m.type == 'EXTENDED_SYS_STATE' and ever_armed and starts['landed'] is None
              and a['last setpoint'] is not None and m.t > a['last setpoint']
              and m.get('landed_state') == mavlink.MAV_LANDED_STATE_ON_GROUND and starts['armed hover'] is not None):
            starts['landed'] = m.t
    if starts['armed hover'] is not None:
        starts['failsafe'] = a['last setpoint']
    return starts


def phases(messages):
    """The flight's phases (Phase tuples, in order), the missing ones left out."""
    a = anchors(messages)
    starts = boundaries(messages)
    marks = [('connecting', a['start'])] + [(name, starts[name]) for name in PHASES[1:] if starts[name] is not None]
    out = []
    for i, (name, start) in enumerate(marks):
        end = marks[i + 1][1] if i + 1 < len(marks) else a['end']
        out.append(Phase(name, start, max(start, end)))
    return out


def phase_of(t, phase_list):
    """The name of the phase at time t (the last one that started by then)."""
    name = phase_list[0].name if phase_list else None
    for p in phase_list:
        if t >= p.start:
            name = p.name
    return name
