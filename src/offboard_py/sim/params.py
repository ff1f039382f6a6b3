"""PX4 parameters of the simulated autopilot: names, types, defaults, ranges, wire encoding.

Defaults are PX4's for a multicopter, except COM_OF_LOSS_T: 0.5 s, the figure of the
tutorial this project ports (PX4 1.12+ ships 1.0; override with COM_OF_LOSS_T=1.0).
INT32 parameters travel bytewise in PARAM_VALUE's float field, as on PX4 (offboard_py.param_codec).
A change takes effect at once: the other modules read values here every time.
"""

import math
from collections import namedtuple

from offboard_py import param_codec
from offboard_py.dialect import mavlink

Param = namedtuple('Param', 'name type default minimum maximum')

_INT, _FLOAT = mavlink.MAV_PARAM_TYPE_INT32, mavlink.MAV_PARAM_TYPE_REAL32
DEFINITIONS = (
    Param('MAV_TYPE', _INT, 2, 0, 43),
    Param('MAV_SYS_ID', _INT, 1, 1, 250),
    Param('COM_OF_LOSS_T', _FLOAT, 0.5, 0.0, 60.0),
    Param('COM_OBL_RC_ACT', _INT, 0, 0, 7),
    Param('COM_RCL_EXCEPT', _INT, 0, 0, 31),
    Param('NAV_RCL_ACT', _INT, 2, 0, 6),
    Param('COM_DISARM_PRFLT', _FLOAT, 10.0, -1.0, 20.0),
    Param('COM_DISARM_LAND', _FLOAT, 2.0, -1.0, 20.0),
    Param('COM_SPOOLUP_TIME', _FLOAT, 1.0, 0.0, 5.0),
    Param('MIS_TAKEOFF_ALT', _FLOAT, 2.5, 0.0, 80.0),
    Param('NAV_ACC_RAD', _FLOAT, 10.0, 0.05, 200.0),
    Param('NAV_MC_ALT_RAD', _FLOAT, 0.8, 0.05, 200.0),
    Param('RTL_RETURN_ALT', _FLOAT, 60.0, 0.0, 150.0),
    Param('RTL_DESCEND_ALT', _FLOAT, 30.0, 2.0, 100.0),
    Param('RTL_MIN_DIST', _FLOAT, 10.0, 0.5, 100.0),
    Param('MPC_Z_VEL_MAX_UP', _FLOAT, 3.0, 0.5, 8.0),
    Param('MPC_Z_VEL_MAX_DN', _FLOAT, 1.5, 0.5, 4.0),
    Param('MPC_XY_VEL_MAX', _FLOAT, 12.0, 0.0, 20.0),
    Param('MPC_XY_CRUISE', _FLOAT, 5.0, 3.0, 20.0),
    Param('MPC_TKO_SPEED', _FLOAT, 1.5, 1.0, 5.0),
    Param('MPC_TKO_RAMP_T', _FLOAT, 3.0, 0.0, 5.0),
    Param('MPC_LAND_SPEED', _FLOAT, 0.7, 0.6, 4.0),
    Param('MPC_LAND_ALT1', _FLOAT, 10.0, 0.0, 122.0),
    Param('MPC_LAND_ALT2', _FLOAT, 5.0, 0.0, 122.0),
    Param('MPC_ACC_HOR_MAX', _FLOAT, 5.0, 2.0, 15.0),
    Param('MPC_ACC_UP_MAX', _FLOAT, 4.0, 2.0, 15.0),
    Param('MPC_ACC_DOWN_MAX', _FLOAT, 3.0, 2.0, 15.0),
    Param('MPC_TILTMAX_AIR', _FLOAT, 45.0, 20.0, 89.0),
    Param('MPC_XY_P', _FLOAT, 0.95, 0.0, 2.0),
    Param('MPC_Z_P', _FLOAT, 1.0, 0.1, 1.5),
    Param('MPC_XY_VEL_P_ACC', _FLOAT, 1.8, 1.2, 5.0),
    Param('MPC_Z_VEL_P_ACC', _FLOAT, 4.0, 2.0, 15.0),
    Param('SYS_FAILURE_EN', _INT, 0, 0, 1),
)


class ParamRejected(ValueError):
    """A set that PX4 would refuse: unknown name, wrong value. The message says why."""


class ParamStore:
    """The parameter table: ordered (PARAM_VALUE index), typed, range-checked."""

    def __init__(self, overrides=None, system_id=1):
        self._defs = {p.name: p for p in DEFINITIONS}
        self.names = [p.name for p in DEFINITIONS]
        self._values = {p.name: p.default for p in DEFINITIONS}
        self._values['MAV_SYS_ID'] = system_id
        for name, value in (overrides or {}).items():
            self.set(name, value)

    def __len__(self):
        return len(self.names)

    def __getitem__(self, name):
        return self._values[name]

    def definition(self, name):
        return self._defs[name]

    def index(self, name):
        return self.names.index(name)

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
        else:
            value = float(value)
        if not p.minimum <= value <= p.maximum:
            raise ParamRejected('%s=%r is outside [%g, %g]' % (name, value, p.minimum, p.maximum))
        self._values[name] = value
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
