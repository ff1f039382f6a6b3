#!/usr/bin/env python3
"""The tutorial's node flying a figure of eight instead of a hover: offb_node.py with its own setpoint_at().

Everything else is offb_node.py's (the pre-stream, OFFBOARD, arming, its parameters): only where the vehicle
should be changes over time. The figure is a lemniscate of Gerono at ~z (2 m) through (~x, ~y), ~radius either
way along x and half that along y, a lap every ~period seconds:

    rosrun offboard_py offb_figure.py [_radius:=2 _period:=20 _z:=2 ...]
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))  # offb_node.py lies beside this file
import offb_node  # noqa: E402
from offboard_py.offboard import ParamError  # noqa: E402

FIGURE = {'radius': 2.0, 'period': 20.0}  # m, s: the defaults, then the node's ~radius and ~period


def read_figure_params(get):
    for name in FIGURE:
        value = get(name, FIGURE[name])
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ParamError(name, 'expected a number > 0, got %r' % (value,))
        FIGURE[name] = float(value)


def figure_at(t, config):
    """A figure of eight through (~x, ~y), out along +x first, yaw held."""
    a = 2.0 * math.pi * t / FIGURE['period']
    r = FIGURE['radius']
    return config.x + r * math.sin(a), config.y + r * math.sin(a) * math.cos(a), config.z, config.yaw


if __name__ == '__main__':
    sys.exit(offb_node.main(figure_at, node_name='offb_figure_py', read_params=read_figure_params))
