"""The figures of PX4 and mavros that tests hold, read from this repository's reference/ (the recordings of the
real stack and the source figures, each naming where it comes from); never a constant of the code under test.

  px4_param(name)          PX4 SITL's value of a parameter as recorded (px4-sitl-params-indexed.tsv, all 888)
  px4_rate_hz(message)     the rate PX4 SITL sends a message at on the onboard link (px4-sitl-census.json)
  px4_figure(module, name) a figure of PX4's source the recordings do not show (px4-source-figures.json)
  px4_rc_loss_seen_s()     COM_RC_LOSS_T as PX4's ManualControl sees it: at its first look after it
  mavros_figure(plugin, name)  a figure of mavros 1.21's source (mavros-1.21-figures.json)
  load(name)               any file of reference/: JSON parsed, other text as it is

The markdown tables of px4-sitl-measured.md are read by measured_tables.
"""

import functools
import json
import math
import os

# the source tree's reference/ (the package runs from it in a catkin devel space and in the offline tiers)
REFERENCE = os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', '..', 'reference')


@functools.lru_cache(maxsize=None)
def _text(name):
    with open(os.path.join(REFERENCE, name)) as f:
        return f.read()


def load(name):
    """A file of reference/ (read once): JSON parsed afresh for each caller, other text as it is."""
    return json.loads(_text(name)) if name.endswith('.json') else _text(name)


def _figure(file_name, group, name):
    return load(file_name)[group][name]['value']


def mavros_figure(plugin, name):
    """mavros 1.21.0's, e.g. mavros_figure('param', 'param_set_sends')."""
    return _figure('mavros-1.21-figures.json', plugin, name)


def px4_figure(module, name):
    """PX4 main 02e73e3b6f's, e.g. px4_figure('mavlink', 'statustext_stream_hz')."""
    return _figure('px4-source-figures.json', module, name)


@functools.lru_cache(maxsize=None)
def _params():
    """{name: value} of the 888 (name, type, value, index) rows."""
    rows = (line.split('\t') for line in _text('px4-sitl-params-indexed.tsv').splitlines() if line)
    return {name: int(value) if kind == 'INT32' else float(value) for name, kind, value, _ in rows}


def px4_param(name):
    """PX4 SITL's value of parameter `name` (int or float, as its type), e.g. px4_param('COM_OF_LOSS_T') == 1.0."""
    try:
        return _params()[name]
    except KeyError:
        raise KeyError('%s is not a parameter of PX4 SITL (reference/px4-sitl-params-indexed.tsv)' % name) from None


def px4_rc_loss_seen_s():
    """When PX4 counts manual control lost after its last sample: ManualControl looks every look_period_s without
    one (ScheduleDelayed(200_ms)) and sees COM_RC_LOSS_T at its first look after it (0.6 s for 0.5 s)."""
    look_s = px4_figure('manual_control', 'look_period_s')
    return look_s * math.floor(px4_param('COM_RC_LOSS_T') / look_s + 1)


def px4_rate_hz(message):
    """The rate (Hz) PX4 SITL sends `message` at on the onboard link, e.g. px4_rate_hz('HEARTBEAT') == 1.0."""
    return load('px4-sitl-census.json')['rates_hz'][message]
