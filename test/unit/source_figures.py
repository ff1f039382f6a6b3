"""Figures of mavros's and PX4's source that tests hold: read from reference/mavros-1.21-figures.json and
reference/px4-source-figures.json, which name the file and constant each comes from; never the constant of
the code under test."""

import json
import os

REFERENCE = os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', 'reference')


def _figure(file_name, group, name):
    with open(os.path.join(REFERENCE, file_name)) as f:
        return json.load(f)[group][name]['value']


def mavros_figure(plugin, name):
    """mavros 1.21.0's, e.g. mavros_figure('param', 'param_set_sends')."""
    return _figure('mavros-1.21-figures.json', plugin, name)


def px4_figure(module, name):
    """PX4 main 02e73e3b6f's, e.g. px4_figure('mavlink', 'statustext_stream_hz')."""
    return _figure('px4-source-figures.json', module, name)
