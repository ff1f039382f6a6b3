"""The simulated PX4's parameter table against PX4 SITL's: names, types, values, order, checks.

The reference recording (shared/reference/px4-sitl-params.tsv, one PARAM_REQUEST_LIST pass of
real PX4 SITL) is read at test time when it is beside the clone (../shared/reference from the
repository root, as on CI); without it those checks are skipped with the reason printed.
"""

import os

import pytest

from offboard_py import param_codec
from offboard_py.dialect import mavlink
from offboard_py.sim import params as sim_params
from offboard_py.sim.params import DEFINITIONS, ParamRejected, ParamStore

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
REFERENCE = os.path.join(os.path.dirname(REPO), 'shared', 'reference', 'px4-sitl-params.tsv')
PX4_PARAM_COUNT = 888    # PX4 SITL's param_count (px4-sitl-census.json)
TABLE_COUNT = 887        # what the table holds: one of PX4's 888 is not identified (sim/params.py)
INT32, REAL32 = mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32
TYPE_NAMES = {'INT32': INT32, 'REAL32': REAL32}


@pytest.fixture(scope='module')
def reference():
    if not os.path.exists(REFERENCE):
        reason = 'PX4 SITL reference %s not found (CI has shared/ beside the clone)' % REFERENCE
        print(reason)
        pytest.skip(reason)
    rows = {}
    with open(REFERENCE) as f:
        for line in f:
            name, type_name, text = line.rstrip('\n').split('\t')
            rows[name] = (TYPE_NAMES[type_name], float(text))
    return rows


def test_the_table_is_px4s_size_unique_and_in_px4s_order():
    names = [p.name for p in DEFINITIONS]
    assert len(names) == TABLE_COUNT, 'PX4 SITL has %d; the table has %d' % (PX4_PARAM_COUNT, len(names))
    assert len(set(names)) == len(names), 'duplicate names'
    assert names == sorted(names, key=lambda n: n.encode()), 'PX4 sends them sorted by name (byte order)'
    assert all(len(n) <= 16 and n == n.upper() for n in names), 'PX4 names: upper case, at most 16 characters'
    store = ParamStore()
    assert len(store) == TABLE_COUNT and store.index(names[0]) == 0 and store.index(names[-1]) == TABLE_COUNT - 1
    assert store.names[:3] == ['ATT_EN', 'BAT1_CAPACITY', 'BAT1_N_CELLS']


def test_types_are_int32_or_real32_and_defaults_fit_them():
    for p in DEFINITIONS:
        assert p.type in (INT32, REAL32), p
        if p.type == INT32:
            assert isinstance(p.default, int) and sim_params.INT32_MIN <= p.default <= sim_params.INT32_MAX, p
        else:
            assert isinstance(p.default, float), p


def test_named_parameters_have_px4_sitl_types_and_values():
    store = ParamStore()
    for name, param_type, value in (('SYS_AUTOSTART', INT32, 10040), ('MPC_XY_VEL_MAX', REAL32, 12.0),
                                    ('RTL_RETURN_ALT', REAL32, 30.0), ('COM_OF_LOSS_T', REAL32, 1.0),
                                    ('NAV_ACC_RAD', REAL32, 2.0), ('RTL_DESCEND_ALT', REAL32, 10.0),
                                    ('SYS_FAILURE_EN', INT32, 1), ('CAL_ACC0_ID', INT32, 1310988)):
        assert (store.definition(name).type, store[name]) == (param_type, value), name


def test_every_reference_row_is_in_the_table_with_its_type_and_value(reference):
    store = ParamStore()
    assert len(reference) == 869
    missing = sorted(set(reference) - set(store.names))
    assert not missing, 'not in the table: %s' % missing
    for name in ('SYS_AUTOSTART', 'MPC_XY_VEL_MAX', 'RTL_RETURN_ALT', 'EKF2_MAG_DECL', 'SENS_BOARD_X_OFF',
                 'CBRK_FLIGHTTERM', 'SIH_LOC_LAT0', 'MC_PITCHRATE_D', 'COM_OF_LOSS_T', 'NAV_ACC_RAD'):
        param_type, value = reference[name]
        assert store.definition(name).type == param_type, name
        assert store[name] == pytest.approx(value, rel=1e-6), name
    wrong = [n for n, (t, v) in reference.items() if store.definition(n).type != t or store[n] != pytest.approx(v)]
    assert not wrong, 'type or value differs from PX4 SITL: %s' % wrong


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
    path.write_text('# header\nGOOD\tINT32\t1\nBAD\tUINT8\t1\n')
    with pytest.raises(ValueError, match='table.tsv:3'):
        sim_params.load_table(str(path))
