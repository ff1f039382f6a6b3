"""PX4's parameters in the simulated autopilot: PX4 SITL's whole table, typed, range-checked
where the simulator models the parameter, with PX4's wire encoding.

The table is px4_params.tsv beside this module: name, type (INT32/REAL32), value and PARAM_VALUE
index of all 888 parameters real PX4 SITL (main 02e73e3b6f, sihsim_quadx, fresh parameters) sends
for a PARAM_REQUEST_LIST, in index order, which is the names' byte order (ASPD_SCALE_1 is index 0):
a copy of reference/px4-sitl-params-indexed.tsv (reference/px4-sitl-measured.md, "Turn 3
recordings", section 1). EKF2_MAG_DECL comes from PX4's world magnetic model and read 3.4056 and
3.40561 in two runs; the table keeps the second.
PX4 starts a full list with _HASH_CHECK (UINT32, index 65535, not counted in param_count; reference/
conversations/takeoff-mavros-px4, t=11.017, seq 221, before index 0): PX4's
CRC32 over the names and values; this simulator sends the value recorded with PX4's defaults
(HASH_CHECK_VALUE), whatever was changed since.

Defaults are PX4 SITL's values, among them COM_OF_LOSS_T 1.0 s; the tutorial's 0.5 s is one
override away (`sim_px4.py COM_OF_LOSS_T=0.5`).
The parameters the simulator reads (RANGES) refuse a value outside PX4's documented range;
every other one is stored and echoed as given, any finite number, as PX4 keeps a value no
module checks. INT32 parameters take integers only, and travel bytewise in PARAM_VALUE's
float field, as on PX4 (offboard_py.param_codec).
A change takes effect at once: the other modules read values here every time.
"""
import math
import os
from collections import namedtuple

from offboard_py import param_codec
from offboard_py.dialect import mavlink

Param = namedtuple('Param', 'name type default minimum maximum')  # minimum, maximum: None when not checked

TABLE_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'px4_params.tsv')
TYPES = {'INT32': mavlink.MAV_PARAM_TYPE_INT32, 'REAL32': mavlink.MAV_PARAM_TYPE_REAL32}
INT32_MIN, INT32_MAX = -2 ** 31, 2 ** 31 - 1
# The list's first PARAM_VALUE (reference/conversations/takeoff-mavros-px4, t=11.017): name, index, value
HASH_CHECK_NAME, HASH_CHECK_INDEX, HASH_CHECK_VALUE = '_HASH_CHECK', 0xFFFF, 0xBD8B05F8

# [minimum, maximum] of the parameters the simulator models (commander, navigator, vehicle), from
# PX4's parameter definitions; PX4 refuses values outside these for the ones its modules check.
RANGES = {
    'MAV_TYPE': (0, 43),
    'MAV_SYS_ID': (1, 250),
    'COM_OF_LOSS_T': (0.0, 60.0),
    'COM_OBL_RC_ACT': (0, 7),
    'COM_RCL_EXCEPT': (0, 31),
    'NAV_RCL_ACT': (0, 6),
    'COM_DISARM_PRFLT': (-1.0, 20.0),
    'COM_DISARM_LAND': (-1.0, 20.0),
    'COM_SPOOLUP_TIME': (0.0, 5.0),
    'MIS_TAKEOFF_ALT': (0.0, 80.0),
    'NAV_ACC_RAD': (0.05, 200.0),
    'NAV_MC_ALT_RAD': (0.05, 200.0),
    'RTL_RETURN_ALT': (0.0, 150.0),
    'RTL_DESCEND_ALT': (2.0, 100.0),
    'RTL_MIN_DIST': (0.5, 100.0),
    'MPC_Z_VEL_MAX_UP': (0.5, 8.0),
    'MPC_Z_VEL_MAX_DN': (0.5, 4.0),
    'MPC_XY_VEL_MAX': (0.0, 20.0),
    'MPC_XY_CRUISE': (3.0, 20.0),
    'MPC_TKO_SPEED': (1.0, 5.0),
    'MPC_TKO_RAMP_T': (0.0, 5.0),
    'MPC_LAND_SPEED': (0.6, 4.0),
    'MPC_LAND_ALT1': (0.0, 122.0),
    'MPC_LAND_ALT2': (0.0, 122.0),
    'MPC_ACC_HOR_MAX': (2.0, 15.0),
    'MPC_ACC_UP_MAX': (2.0, 15.0),
    'MPC_ACC_DOWN_MAX': (2.0, 15.0),
    'MPC_TILTMAX_AIR': (20.0, 89.0),
    'MPC_XY_P': (0.0, 2.0),
    'MPC_Z_P': (0.1, 1.5),
    'MPC_XY_VEL_P_ACC': (1.2, 5.0),
    'MPC_Z_VEL_P_ACC': (2.0, 15.0),
    'SYS_FAILURE_EN': (0, 1),
    # the flight model: PX4's trajectory, velocity control, thrust and return cone
    'MPC_ACC_HOR': (2.0, 15.0),
    'MPC_JERK_AUTO': (1.0, 80.0),
    'MPC_Z_V_AUTO_UP': (0.5, 8.0),
    'MPC_Z_V_AUTO_DN': (0.5, 4.0),
    'MPC_XY_TRAJ_P': (0.1, 1.0),
    'MPC_XY_ERR_MAX': (0.1, 10.0),
    'MPC_XY_VEL_I_ACC': (0.0, 60.0),
    'MPC_XY_VEL_D_ACC': (0.1, 2.0),
    'MPC_Z_VEL_I_ACC': (0.2, 3.0),
    'MPC_Z_VEL_D_ACC': (0.0, 2.0),
    'MPC_THR_HOVER': (0.1, 0.8),
    'MPC_THR_MIN': (0.05, 1.0),
    'MPC_THR_MAX': (0.0, 1.0),
    'RTL_CONE_ANG': (0, 90),
    'MC_ROLLRATE_MAX': (0.0, 1800.0),   # deg/s: the attitude loop's rate limit (vehicle._attitude_loop)
    'MC_PITCHRATE_MAX': (0.0, 1800.0),
    'MC_ROLL_P': (0.0, 12.0),           # the attitude loop's gains
    'MC_PITCH_P': (0.0, 12.0),
    # the RTL time estimate (TIME_ESTIMATE_TO_TARGET)
    'RTL_LAND_DELAY': (-1.0, 300.0),
    'RTL_TIME_FACTOR': (1.0, 2.0),
    'RTL_TIME_MARGIN': (0, 300),
}


def load_table(path=TABLE_PATH, ranges=RANGES):
    """The Params of a table file (NAME<TAB>INT32|REAL32<TAB>value<TAB>index, the index being the
    row's position; '#' starts a comment line), in its order."""
    table = []
    with open(path) as f:
        for line_no, line in enumerate(f, 1):
            if not line.strip() or line.startswith('#'):
                continue
            try:
                name, type_name, text, index = line.rstrip('\n').split('\t')
                param_type = TYPES[type_name]
                default = int(text) if param_codec.is_integer(param_type) else float(text)
                if int(index) != len(table):
                    raise ValueError('index %s where %d was due' % (index, len(table)))
            except (KeyError, ValueError) as err:
                raise ValueError('%s:%d: expected NAME<TAB>INT32|REAL32<TAB>number<TAB>index (%s)'
                                 % (path, line_no, err))
            table.append(Param(name, param_type, default, *ranges.get(name, (None, None))))
    return tuple(table)


DEFINITIONS = load_table()


class ParamRejected(ValueError):
    """A set that PX4 would refuse: unknown name, wrong value. The message says why."""


class ParamStore(dict):
    """The parameter table: ordered (PARAM_VALUE index), typed, range-checked where modelled.

    Read it as a dict of name -> value (a plain dict lookup: the flight model reads some 30
    values a step); a value changes only through set() (or store[name] = value, which is set()),
    which checks it."""

    def __init__(self, overrides=None, system_id=1, definitions=DEFINITIONS):
        super().__init__((p.name, p.default) for p in definitions)
        self._defs = {p.name: p for p in definitions}
        self.names = [p.name for p in definitions]
        self._index = {name: i for i, name in enumerate(self.names)}
        dict.__setitem__(self, 'MAV_SYS_ID', system_id)
        for name, value in (overrides or {}).items():
            self.set(name, value)

    def __setitem__(self, name, value):
        self.set(name, value)

    def definition(self, name):
        return self._defs[name]

    def index(self, name):
        return self._index[name]

    def set(self, name, value):
        """Set `name` to a Python number; raise ParamRejected naming what is wrong."""
        p = self._defs.get(name)
        if p is None:
            raise ParamRejected('unknown parameter %r' % (name,))
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ParamRejected('%s: %r is not a finite number' % (name, value))
        if param_codec.is_integer(p.type):
            if value != int(value):
                raise ParamRejected('%s is an integer parameter, got %r' % (name, value))
            value = int(value)
            if not INT32_MIN <= value <= INT32_MAX:
                raise ParamRejected('%s=%d does not fit INT32 [%d, %d]' % (name, value, INT32_MIN, INT32_MAX))
        else:
            value = float(value)
        if p.minimum is not None and not p.minimum <= value <= p.maximum:
            raise ParamRejected('%s=%r is outside [%g, %g]' % (name, value, p.minimum, p.maximum))
        dict.__setitem__(self, name, value)
        return value

    def parse_override(self, text):
        """Apply a NAME=VALUE command-line override."""
        name, sep, raw = text.partition('=')
        if not sep or not name:
            raise ParamRejected('parameter override %r: expected NAME=VALUE' % (text,))
        try:
            value = float(raw)
        except ValueError:
            raise ParamRejected('parameter override %r: %r is not a number' % (text, raw))
        return self.set(name.strip().upper(), int(value) if value.is_integer() else value)
