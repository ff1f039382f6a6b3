"""Node parameter validation: defaults are the tutorial's, bad values name the parameter."""

import math

import pytest

from offboard_py.offboard import DEFAULTS, ParamError, validate_config


def config(**given):
    return validate_config(lambda name, default: given.get(name, default))


def test_defaults_are_the_tutorials():
    c = config()
    assert (c.rate_hz, c.prestream_count, c.request_interval_s) == (20.0, 100, 5.0)
    assert (c.x, c.y, c.z, c.yaw) == (0.0, 0.0, 2.0, 0.0)
    assert c.respect_pilot is False
    assert c == DEFAULTS


def test_ints_accepted_for_floats():
    c = config(rate=50, z=3, request_interval=2)
    assert (c.rate_hz, c.z, c.request_interval_s) == (50.0, 3.0, 2.0)


@pytest.mark.parametrize('name, value, words', [
    ('rate', 2, 'above 2'),
    ('rate', 1.5, 'above 2'),
    ('rate', 0, 'above 2'),
    ('rate', -20, 'above 2'),
    ('rate', math.nan, 'finite'),
    ('rate', math.inf, 'finite'),
    ('rate', 'fast', 'number'),
    ('rate', True, 'number'),
    ('prestream_count', -1, '0 or more'),
    ('prestream_count', 1.5, 'whole number'),
    ('prestream_count', '100', 'whole number'),
    ('request_interval', -0.1, '0 s or more'),
    ('request_interval', math.nan, 'finite'),
    ('x', math.inf, 'finite'),
    ('y', -math.inf, 'finite'),
    ('z', math.nan, 'finite'),
    ('yaw', 'north', 'number'),
    ('frame_id', 3, 'string'),
    ('respect_pilot', 'yes', 'true or false'),
    ('respect_pilot', 1, 'true or false'),
])
def test_bad_values_name_the_parameter(name, value, words):
    with pytest.raises(ParamError) as info:
        config(**{name: value})
    assert info.value.name == name
    message = str(info.value)
    assert '~' + name in message and words in message, message


def test_rate_just_above_minimum_is_accepted():
    assert config(rate=2.01).rate_hz == 2.01
