"""The simulated PX4's parameter protocol over UDP, as PX4 SITL answers it (no ROS).

PX4 SITL answers PARAM_REQUEST_LIST with all its parameters (param_count 888, the index of each
in name order) in under 1 s on loopback, while its streams go on, and starts the list with
_HASH_CHECK (UINT32, index 65535, not counted; reference/conversations/takeoff-mavros-px4: t=11.017,
seq 221, then index 0 - px4-sitl-measured.md's "ends with" is wrong); it reads a parameter by index with the same name
as in the list, and says nothing for index 888; it echoes every PARAM_SET with the value in force
(reference/px4-sitl-measured.md, "Turn 3 recordings", section 1; the names, types, values and
indices are reference/px4-sitl-params-indexed.tsv). Seconds are simulated ones.
"""

import os
import struct

from offboard_py import param_codec
from offboard_py.dialect import mavlink
from offboard_py.sim.param_store import DEFINITIONS

FAST = ('--ready-delay', '1')
INT32, REAL32 = mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32
TABLE = {p.name: (i, p) for i, p in enumerate(DEFINITIONS)}
REFERENCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'reference',
                         'px4-sitl-params-indexed.tsv')
PX4_NAMES = [line.split('\t')[0] for line in open(REFERENCE)]  # in index order
HASH_CHECK = ('_HASH_CHECK', mavlink.MAV_PARAM_TYPE_UINT32, 65535, 0xBD8B05F8)  # the recording's
READ_BY_INDEX = list(range(19)) + [444, 887]  # the indices PX4 was asked for one by one
LIST_BOUND_S = 10.0        # PX4: under 1 s; ours is paced through its 100 Hz loop
# PX4 SITL sent its 889 PARAM_VALUE in 0.80 s (reference/conversations: the pull from 11.0 to 11.8 s),
# some 11 a 10 ms step of its loop, between its streams: at most 20 between two ATTITUDEs (about one a
# step, 98.5 Hz in PX4's census; takeoff-mavros-px4.compact.jsonl.xz). Bound: three steps' worth. Counted in the order the datagrams came, which
# the machine's load does not change, where a gap in wall time would (a 0.14 s stall of the whole
# process under CI's load once failed a 0.1 s bound at 2x).
PX4_PARAM_VALUES_PER_STEP = 11
MAX_PARAM_VALUES_BETWEEN_ATTITUDES = 3 * PX4_PARAM_VALUES_PER_STEP


def param_values_since(client, start):
    return [(t, m) for t, m in list(client.history[start:]) if m.get_type() == 'PARAM_VALUE']


def past_the_boot_burst(client):
    """Wait for the sixteen PARAM_VALUEs PX4 sends unasked 1.0 s after boot (reference/px4-sitl-boot-params.json),
    so that a test's window holds only what it asked for."""
    client.wait_for(lambda: len(param_values_since(client, 0)) >= 16, 3.0, 'the boot PARAM_VALUEs')
    client.sleep(0.1)


def wait_param_value(client, start, name, timeout_s=2.0):
    return client.wait_for(lambda: next((m for _, m in param_values_since(client, start) if m.param_id == name), None),
                           timeout_s, 'PARAM_VALUE ' + name)


def test_param_request_list_sends_the_whole_table_while_the_streams_go_on(start_sim):
    _, client = start_sim(*FAST)
    past_the_boot_burst(client)
    start = len(client.history)
    t0 = client.now()
    client.send(client.mav.param_request_list_encode(client.target, 1))

    def finished():
        return any(m.param_index == len(PX4_NAMES) - 1 for _, m in param_values_since(client, start))
    client.wait_for(finished, LIST_BOUND_S, 'the whole list (_HASH_CHECK and %d PARAM_VALUE)' % len(PX4_NAMES))
    got = param_values_since(client, start)
    elapsed = got[-1][0] - t0
    print('PARAM_REQUEST_LIST: %d PARAM_VALUE in %.3f s' % (len(got), elapsed))
    assert {m.param_count for _, m in got} == {len(PX4_NAMES)} == {888}, 'param_count as PX4\'s'
    (_, first), *params = got
    assert (first.param_id, first.param_type, first.param_index) == HASH_CHECK[:3], 'the list starts with _HASH_CHECK'
    assert struct.unpack('<I', struct.pack('<f', first.param_value))[0] == HASH_CHECK[3]
    by_index = {m.param_index: m for _, m in params}
    assert len(params) == len(by_index) == 888, 'each parameter once'
    assert [by_index[i].param_id for i in range(888)] == PX4_NAMES, 'PX4\'s names at PX4\'s indices'
    for name, value in (('SYS_AUTOSTART', 10040), ('MPC_XY_VEL_MAX', 12.0), ('RTL_RETURN_ALT', 30.0)):
        index, p = TABLE[name]
        m = by_index[index]
        assert (m.param_id, m.param_type) == (name, p.type)
        assert param_codec.decode(m.param_type, m.param_value) == value, name
    # the 100 Hz loop went on: ATTITUDE kept coming between the list's batches
    during = [(t, m.get_type()) for t, m in list(client.history[start:]) if t0 <= t <= got[-1][0]]
    attitude = [t for t, kind in during if kind == 'ATTITUDE']
    gaps = [b - a for a, b in zip([t0] + attitude, attitude + [got[-1][0]])]
    runs, run = [], 0
    for _, kind in during:
        if kind == 'PARAM_VALUE':
            run += 1
        elif kind == 'ATTITUDE':
            runs.append(run)
            run = 0
    runs.append(run)
    print('ATTITUDE during the list: %d, longest gap %.3f s, most PARAM_VALUE between two: %d' % (
        len(attitude), max(gaps), max(runs)))
    assert max(runs) <= MAX_PARAM_VALUES_BETWEEN_ATTITUDES, (
        '%d PARAM_VALUE went out with no ATTITUDE between them: the list held up the loop (PX4: %d a step)'
        % (max(runs), PX4_PARAM_VALUES_PER_STEP))


def test_a_second_param_request_list_under_way_starts_again_at_index_0_without_the_hash_check(start_sim):
    """PX4's MavlinkParametersManager: a PARAM_REQUEST_LIST while a list is under way sets the next
    index to 0 ("a restart should skip the hash check on the ground"), so one _HASH_CHECK only."""
    _, client = start_sim(*FAST)
    past_the_boot_burst(client)
    start = len(client.history)
    client.send(client.mav.param_request_list_encode(client.target, 1))
    client.wait_for(lambda: any(m.param_index == 100 for _, m in param_values_since(client, start)), LIST_BOUND_S,
                    'index 100 of the first list')
    client.send(client.mav.param_request_list_encode(client.target, 1))

    def index_0_twice():
        return [m.param_index for _, m in param_values_since(client, start)].count(0) == 2
    client.wait_for(index_0_twice, LIST_BOUND_S, 'index 0 again after the second request')
    client.wait_for(lambda: any(m.param_index == len(PX4_NAMES) - 1 for _, m in param_values_since(client, start)),
                    LIST_BOUND_S, 'the end of the list')
    client.sleep(0.5)
    got = [m.param_index for _, m in param_values_since(client, start)]
    assert got.count(HASH_CHECK[2]) == 1, 'PX4 sends _HASH_CHECK once for the two requests'
    assert got[0] == HASH_CHECK[2]
    second = len(got) - 1 - got[::-1].index(0)  # where the second request's table starts
    assert got[second:] == list(range(len(PX4_NAMES))), 'the whole table again from index 0, once'


def test_param_request_read_by_index_names_what_the_list_names_and_888_gets_no_answer(start_sim):
    _, client = start_sim(*FAST)
    past_the_boot_burst(client)
    for index in READ_BY_INDEX:
        start = len(client.history)
        client.send(client.mav.param_request_read_encode(client.target, 1, b'', index))
        value = client.wait_for(lambda: next((m for _, m in param_values_since(client, start)), None), 2.0,
                                'PARAM_VALUE for index %d' % index)
        assert (value.param_id, value.param_index) == (PX4_NAMES[index], index)
    start = len(client.history)
    client.send(client.mav.param_request_read_encode(client.target, 1, b'', 888))
    client.sleep(1.0)
    assert not param_values_since(client, start), 'PX4 does not answer index 888'


def test_param_set_is_echoed_for_unmodelled_and_modelled_parameters(start_sim):
    _, client = start_sim(*FAST)
    past_the_boot_burst(client)  # SYS_AUTOSTART is one of them
    # SYS_AUTOSTART: no module of ours reads it; PX4 stores and echoes it (INT32, bytewise)
    start = len(client.history)
    wire = struct.unpack('<f', struct.pack('<i', 4001))[0]
    client.send(client.mav.param_set_encode(client.target, 1, b'SYS_AUTOSTART', wire, INT32))
    echo = wait_param_value(client, start, 'SYS_AUTOSTART')
    assert (echo.param_type, echo.param_index, echo.param_count) == (INT32, TABLE['SYS_AUTOSTART'][0], len(DEFINITIONS))
    assert param_codec.decode(INT32, echo.param_value) == 4001
    start = len(client.history)
    client.send(client.mav.param_request_read_encode(client.target, 1, b'', TABLE['SYS_AUTOSTART'][0]))
    assert param_codec.decode(INT32, wait_param_value(client, start, 'SYS_AUTOSTART').param_value) == 4001
    # modelled ones: in range taken, out of range refused with the value in force echoed
    for name, value in (('MPC_XY_VEL_MAX', 8.0), ('RTL_RETURN_ALT', 45.0)):
        start = len(client.history)
        client.send(client.mav.param_set_encode(client.target, 1, name.encode(), value, REAL32))
        assert wait_param_value(client, start, name).param_value == value
    start = len(client.history)
    client.send(client.mav.param_set_encode(client.target, 1, b'RTL_RETURN_ALT', 500.0, REAL32))
    assert wait_param_value(client, start, 'RTL_RETURN_ALT').param_value == 45.0, 'RTL_RETURN_ALT is 0..150 m'


def test_param_set_errors_as_px4s_parameter_manager(start_sim):
    """What PX4 main's MAVLink parameter manager cannot apply gets PARAM_ERROR (345) for the requester,
    the parameter named, index -1, and nothing changes: _HASH_CHECK (READ_ONLY), an unknown name
    (DOES_NOT_EXIST), a type other than INT32 and REAL32 (TYPE_UNSUPPORTED), the other of the two
    (TYPE_MISMATCH). A PARAM_SET for system 0 is not for PX4's parameters: no answer."""
    _, client = start_sim(*FAST)
    past_the_boot_burst(client)
    int_wire = struct.unpack('<f', struct.pack('<i', 2))[0]
    cases = [(b'_HASH_CHECK', 1.0, REAL32, mavlink.MAV_PARAM_ERROR_READ_ONLY),
             (b'NO_SUCH_PARAM', 1.0, REAL32, mavlink.MAV_PARAM_ERROR_DOES_NOT_EXIST),
             (b'COM_OBL_RC_ACT', int_wire, mavlink.MAV_PARAM_TYPE_UINT8, mavlink.MAV_PARAM_ERROR_TYPE_UNSUPPORTED),
             (b'COM_OBL_RC_ACT', 2.0, REAL32, mavlink.MAV_PARAM_ERROR_TYPE_MISMATCH),
             (b'MIS_TAKEOFF_ALT', int_wire, INT32, mavlink.MAV_PARAM_ERROR_TYPE_MISMATCH)]
    for name, value, wire_type, error in cases:
        start = len(client.history)
        client.send(client.mav.param_set_encode(client.target, 1, name, value, wire_type))
        answer = client.wait_for(lambda: next((m for _, m in client.history[start:] if m.get_type() == 'PARAM_ERROR'),
                                              None), 2.0, 'PARAM_ERROR for %s' % name.decode())
        assert (answer.param_id, answer.param_index, answer.error) == (name.decode(), -1, error)
        assert (answer.target_system, answer.target_component) == (client.mav.srcSystem, client.mav.srcComponent)
        assert not param_values_since(client, start), 'nothing set, nothing echoed'
    start = len(client.history)
    client.send(client.mav.param_set_encode(0, 1, b'MIS_TAKEOFF_ALT', 3.0, REAL32))
    client.sleep(0.5)
    assert not param_values_since(client, start), 'system 0: PX4 does not take it'
    for name in ('COM_OBL_RC_ACT', 'MIS_TAKEOFF_ALT'):
        start = len(client.history)
        client.send(client.mav.param_request_read_encode(client.target, 1, name.encode(), -1))
        echo = wait_param_value(client, start, name)
        assert param_codec.decode(echo.param_type, echo.param_value) == TABLE[name][1].default
