"""The figures tests hold are the measurement's: every PX4 number in reference/px4-sitl-flight-figures.json (read by
test/sim/test_flight_fit.py and test/rostest/test_mission.py) stands in reference/px4-sitl-measured.md, the record
of how it was measured, so a copy cannot drift from it unnoticed. (The file's traces are resampled from
reference/px4-sitl-trace.csv and px4-sitl-auto-trace.csv, as its "source" says.)"""

import json
import os

import pytest

REFERENCE = os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', 'reference')


def load(name):
    with open(os.path.join(REFERENCE, name)) as f:
        return json.load(f) if name.endswith('.json') else f.read()


def figures():
    data = load('px4-sitl-flight-figures.json')
    for group, values in list(data['figures'].items()) + [('not_compared', data['not_compared'])]:
        for name, runs in values.items():
            for value in runs:
                yield '%s / %s' % (group, name), value


@pytest.mark.parametrize('where, value', list(figures()))
def test_each_figure_is_in_the_measurement_record(where, value):
    text = load('px4-sitl-measured.md')
    spellings = {'%g' % value, '%.2f' % value}
    assert any(spelling in text for spelling in spellings), \
        '%s: %r is not in reference/px4-sitl-measured.md' % (where, value)
