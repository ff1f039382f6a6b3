"""The figures of PX4 and mavros that tests hold, read from this repository's reference/ (the recordings of the
real stack and the source figures, each naming where it comes from); never a constant of the code under test.

  px4_param(name)          PX4 SITL's value of a parameter as recorded (px4-sitl-params-indexed.tsv, all 888)
  px4_rate_hz(message)     the rate PX4 SITL sends a message at on the onboard link (px4-sitl-census.json)
  px4_figure(module, name) a figure of PX4's source the recordings do not show (px4-source-figures.json)
  mavros_figure(plugin, name)  a figure of mavros 1.21's source (mavros-1.21-figures.json)
  load(name)               any file of reference/: JSON parsed, other text as it is

The markdown tables of px4-sitl-measured.md are read by measured_tables.
"""

import json
import os

# the source tree's reference/ (the package runs from it in a catkin devel space and in the offline tiers)
REFERENCE = os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', '..', 'reference')


def load(name):
    with open(os.path.join(REFERENCE, name)) as f:
        return json.load(f) if name.endswith('.json') else f.read()


def _figure(file_name, group, name):
    return load(file_name)[group][name]['value']


def mavros_figure(plugin, name):
    """mavros 1.21.0's, e.g. mavros_figure('param', 'param_set_sends')."""
    return _figure('mavros-1.21-figures.json', plugin, name)


def px4_figure(module, name):
    """PX4 main 02e73e3b6f's, e.g. px4_figure('mavlink', 'statustext_stream_hz')."""
    return _figure('px4-source-figures.json', module, name)


def px4_param(name):
    """PX4 SITL's value of parameter `name` (int or float, as its type), e.g. px4_param('COM_OF_LOSS_T') == 1.0."""
    for line in load('px4-sitl-params-indexed.tsv').splitlines():
        fields = line.split('\t')
        if fields[0] == name:
            return int(fields[2]) if fields[1] == 'INT32' else float(fields[2])
    raise KeyError('%s is not a parameter of PX4 SITL (reference/px4-sitl-params-indexed.tsv)' % name)


def px4_rate_hz(message):
    """The rate (Hz) PX4 SITL sends `message` at on the onboard link, e.g. px4_rate_hz('HEARTBEAT') == 1.0."""
    return load('px4-sitl-census.json')['rates_hz'][message]
