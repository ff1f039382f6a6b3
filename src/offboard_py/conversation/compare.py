"""Two recordings' figures (analysis.Summary) held to each other: the differences, each named by its key.

Tolerances (reference/px4-sitl-measured.md, "Recorded conversations": two runs of real PX4 differ by
this much, see reference/conversations/README.md):
  'rate'   10 % of the reference, or the figures' own slack (1.5 messages over the phase), whichever is more;
  'time'   10 % of the reference, or TIME_FLOOR_S, or the figures' slack, whichever is more;
  'count'  10 % of the reference rounded down (so a count under 10 must be equal);
  'value'  equal.
A figure that one recording has and the other has not is a difference too (a message type one side
never sends in a phase, a command never answered, a transaction one side never starts).
"""

import collections
import fnmatch

from offboard_py.conversation.analysis import Figure

REL_TOLERANCE = 0.10
# the time floor: at 5x simulated speed (OFFBOARD_PY_SPEED, as the CI flights run) 20 ms of a loaded
# machine's scheduling are 0.1 simulated seconds; real mavros's own ACK delays are 8-12 ms
TIME_FLOOR_S = 0.1

DIRECTION_PREFIXES = {  # which side of the link a figure is about, by its key
    'ros': ('rate/ros/', 'first/ros/', 'command/ros/', 'mission/ros/', 'param/ros/', 'timesync/ros/', 'seq/ros/',
            'heartbeat/ros/'),
    'fcu': ('rate/fcu/', 'first/fcu/', 'command/fcu/', 'mission/fcu/', 'param/fcu/', 'timesync/fcu/', 'seq/fcu/',
            'heartbeat/fcu/', 'mode/fcu/', 'system_status/fcu/', 'landed_state/fcu/'),
}


class Difference(collections.namedtuple('Difference', 'key reference ours why')):
    """One figure that differs: its key, both values (None: absent there) and how it differs."""

    def __str__(self):
        return '%s: reference %s, ours %s (%s)' % (self.key, _show(self.reference), _show(self.ours), self.why)


def _show(value):
    return 'absent' if value is None else str(value)


def side_of(key):
    """'ros', 'fcu' or 'both' (phases)."""
    for side, prefixes in DIRECTION_PREFIXES.items():
        if key.startswith(prefixes):
            return side
    return 'both'


def tolerance(ref, ours):
    """The allowed absolute difference of two figures of the same kind."""
    if ref.kind == 'rate':
        return max(REL_TOLERANCE * abs(ref.value), ref.slack, ours.slack)
    if ref.kind == 'time':
        return max(REL_TOLERANCE * abs(ref.value), TIME_FLOOR_S, ref.slack, ours.slack)
    if ref.kind == 'count':
        return int(REL_TOLERANCE * abs(ref.value))
    return 0


def differ(ref, ours):
    """The reason two figures differ, or None."""
    if ref.kind == 'value' or ours.kind == 'value' or not isinstance(ref.value, (int, float)) \
            or not isinstance(ours.value, (int, float)):
        return None if ref.value == ours.value else 'not equal'
    allowed = tolerance(ref, ours)
    delta = ours.value - ref.value
    if abs(delta) <= allowed + 1e-9:
        return None
    if ref.value:
        return '%+.0f %%, allowed %g' % (100.0 * delta / abs(ref.value), round(allowed, 4))
    return '%+g, allowed %g' % (round(delta, 4), round(allowed, 4))


def compare(reference, ours, sides=('ros', 'fcu', 'both')):
    """[Difference] between two Summaries, over the figures of `sides`, in the reference's key order
    then ours."""
    out = []
    keys = list(reference.figures) + [k for k in ours.figures if k not in reference.figures]
    for key in keys:
        if side_of(key) not in sides:
            continue
        ref, mine = reference.figures.get(key), ours.figures.get(key)
        if key.startswith('rate/') and (ref is None or mine is None):
            # a rate absent is a rate of 0: a one-off message in another phase is within the slack
            present = ref or mine
            zero = Figure(0.0, 'rate', present.slack)
            why = differ(ref or zero, mine or zero)
            if why:
                out.append(Difference(key, ref and ref.value, mine and mine.value,
                                      'only ours' if ref is None else 'only the reference'))
            continue
        if ref is None:
            out.append(Difference(key, None, mine.value, 'only ours'))
        elif mine is None:
            out.append(Difference(key, ref.value, None, 'only the reference'))
        else:
            why = differ(ref, mine)
            if why:
                out.append(Difference(key, ref.value, mine.value, why))
    return out


def split_accepted(differences, accepted):
    """(unaccepted, accepted [(Difference, reason)], unused patterns) for `accepted` {fnmatch pattern: reason}."""
    left, taken, used = [], [], set()
    for d in differences:
        reason = next(((p, r) for p, r in accepted.items() if fnmatch.fnmatchcase(d.key, p)), None)
        if reason is None:
            left.append(d)
        else:
            used.add(reason[0])
            taken.append((d, reason[1]))
    return left, taken, [p for p in accepted if p not in used]
