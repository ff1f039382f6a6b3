"""The simulated PX4's parameter table against PX4 SITL's: names, types, values, indices, checks.

The reference is reference/px4-sitl-params-indexed.tsv in this repository: all 888 parameters
real PX4 SITL sent for one PARAM_REQUEST_LIST (name, type, value, PARAM_VALUE index), recorded
as reference/px4-sitl-measured.md ("Turn 3 recordings", section 1) describes.
"""

import os
import re
import struct

import pytest

from offboard_py import param_codec
from offboard_py.dialect import mavlink
from offboard_py.sim import param_store as sim_params
from offboard_py.sim.param_store import DEFINITIONS, ParamRejected, ParamStore

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
REFERENCE = os.path.join(REPO, 'reference', 'px4-sitl-params-indexed.tsv')
INT32, REAL32 = mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32
TYPE_NAMES = {'INT32': INT32, 'REAL32': REAL32}
# varies by run (the world magnetic model): 3.4056 and 3.40561 in the two recorded runs
RUN_DEPENDENT = {'EKF2_MAG_DECL': 1e-4}


def float32(value):
    return struct.unpack('<f', struct.pack('<f', value))[0]


def load_reference():
    rows = []
    with open(REFERENCE) as f:
        for line in f:
            name, type_name, text, index = line.rstrip('\n').split('\t')
            rows.append((name, TYPE_NAMES[type_name], float(text), int(index)))
    return rows


REFERENCE_ROWS = load_reference()


def test_the_reference_is_whole():
    assert len(REFERENCE_ROWS) == 888, 'PX4 SITL\'s param_count'
    assert [r[3] for r in REFERENCE_ROWS] == list(range(888))
    assert sum(1 for r in REFERENCE_ROWS if r[1] == REAL32) == 602, 'reference/px4-sitl-measured.md: 602 REAL32'


def test_every_row_of_px4s_list_is_in_the_table_with_its_name_type_value_and_index():
    store = ParamStore()
    assert len(DEFINITIONS) == len(store) == len(REFERENCE_ROWS)
    wrong = []
    for name, param_type, value, index in REFERENCE_ROWS:
        p = DEFINITIONS[index]
        if p.name != name or store.index(name) != index or p.type != param_type:
            wrong.append('%d: %s %d, PX4 %s %d' % (index, p.name, p.type, name, param_type))
            continue
        ours = float32(store[name])
        tolerance = RUN_DEPENDENT.get(name)
        if (ours != float32(value)) if tolerance is None else abs(ours - value) > tolerance * abs(value):
            wrong.append('%s = %r, PX4 %r' % (name, store[name], value))
    assert not wrong, 'differs from PX4 SITL: %s' % wrong


def test_the_table_is_in_px4s_order_unique_and_well_formed():
    names = [p.name for p in DEFINITIONS]
    assert len(set(names)) == len(names), 'duplicate names'
    assert names == sorted(names, key=lambda n: n.encode()), 'PX4 sends them sorted by name (byte order)'
    assert all(len(n) <= 16 and n == n.upper() for n in names), 'PX4 names: upper case, at most 16 characters'
    assert names[:2] == ['ASPD_SCALE_1', 'ATT_EN'], 'index 0 is ASPD_SCALE_1'


def test_the_hash_check_is_px4s_and_not_a_parameter():
    """Name, index and value as reference/px4-sitl-measured.md records PX4 SITL's `_HASH_CHECK`."""
    with open(os.path.join(REPO, 'reference', 'px4-sitl-measured.md')) as f:
        name, index, value = re.search(r'`(_HASH_CHECK)` \(type UINT32, param_index (\d+), value (0x[0-9A-F]+)\)',
                                       f.read()).groups()
    assert (sim_params.HASH_CHECK_NAME, sim_params.HASH_CHECK_INDEX, sim_params.HASH_CHECK_VALUE) == \
        (name, int(index), int(value, 16))
    assert sim_params.HASH_CHECK_NAME not in ParamStore()


def test_types_are_int32_or_real32_and_defaults_fit_them():
    for p in DEFINITIONS:
        assert p.type in (INT32, REAL32), p
        if p.type == INT32:
            assert isinstance(p.default, int) and sim_params.INT32_MIN <= p.default <= sim_params.INT32_MAX, p
        else:
            assert isinstance(p.default, float), p


def test_the_modelled_parameters_are_px4s_with_a_range_around_the_default():
    for name, (low, high) in sim_params.RANGES.items():
        p = ParamStore().definition(name)
        assert (p.minimum, p.maximum) == (low, high)
        assert low <= p.default <= high, '%s default %r outside [%g, %g]' % (name, p.default, low, high)
    unchecked = [p for p in DEFINITIONS if p.name not in sim_params.RANGES]
    assert all(p.minimum is None and p.maximum is None for p in unchecked)


def test_a_modelled_parameter_refuses_a_value_outside_its_range():
    store = ParamStore()
    with pytest.raises(ParamRejected, match=r'RTL_RETURN_ALT=500.0 is outside \[0, 150\]'):
        store.set('RTL_RETURN_ALT', 500.0)
    assert store['RTL_RETURN_ALT'] == 30.0
    assert store.set('RTL_RETURN_ALT', 60) == 60.0 and isinstance(store['RTL_RETURN_ALT'], float)
    assert store.set('MPC_XY_VEL_MAX', 8.0) == 8.0


def test_an_unmodelled_parameter_is_stored_and_echoed_as_given():
    store = ParamStore()
    assert store.set('SYS_AUTOSTART', 4001) == 4001 and store['SYS_AUTOSTART'] == 4001
    assert store.set('EKF2_MAG_DECL', -1234.5) == -1234.5  # no range: any finite number
    assert store.set('CBRK_SUPPLY_CHK', 894281) == 894281
    wire = param_codec.encode(INT32, store['SYS_AUTOSTART'])
    assert param_codec.decode(INT32, wire) == 4001, 'INT32 travels bytewise'
    for bad, words in ((4001.5, 'integer'), (2 ** 31, 'INT32'), (float('inf'), 'finite'), (True, 'finite')):
        with pytest.raises(ParamRejected, match=words):
            store.set('SYS_AUTOSTART', bad)
    assert store['SYS_AUTOSTART'] == 4001


def test_command_line_overrides_keep_the_tutorials_figure_one_argument_away():
    store = ParamStore()
    assert store.parse_override('COM_OF_LOSS_T=0.5') == 0.5 and store['COM_OF_LOSS_T'] == 0.5
    assert store.parse_override('sys_autostart=4001') == 4001
    with pytest.raises(ParamRejected, match='unknown'):
        store.parse_override('NOT_A_PARAM=1')


def test_a_malformed_table_line_is_named(tmp_path):
    path = tmp_path / 'table.tsv'
    path.write_text('# header\nGOOD\tINT32\t1\t0\nBAD\tUINT8\t1\t1\n')
    with pytest.raises(ValueError, match='table.tsv:3'):
        sim_params.load_table(str(path))
    path.write_text('GOOD\tINT32\t1\t0\nSKIPPED\tINT32\t1\t2\n')
    with pytest.raises(ValueError, match=r'table.tsv:2: .*index 2 where 1 was due'):
        sim_params.load_table(str(path))
