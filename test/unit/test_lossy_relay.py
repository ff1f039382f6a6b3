"""The lossy relay's control protocol, offline: "cut SECONDS [direction]" and "drop P SECONDS [direction]"."""

import pytest

from offboard_py.testing.lossy_relay import Control, parse_control


def test_cut_defaults_to_both_directions():
    assert parse_control('cut 2') == Control('cut', 2.0, ('fcu', 'bridge'), 1.0)
    assert parse_control('cut 0.5 to_fcu') == Control('cut', 0.5, ('bridge',), 1.0)  # sides that receive
    assert parse_control(' cut 8 to_bridge\n') == Control('cut', 8.0, ('fcu',), 1.0)


def test_drop_burst_takes_a_probability_and_a_length():
    assert parse_control('drop 0.2 30') == Control('drop', 30.0, ('fcu', 'bridge'), 0.2)
    assert parse_control('drop 1 5 to_fcu') == Control('drop', 5.0, ('bridge',), 1.0)
    assert parse_control('drop 0 10 both').drop == 0.0


@pytest.mark.parametrize('text, reason', [
    ('', 'expected "cut SECONDS'),
    ('cut', 'expected "cut SECONDS'),
    ('cut 1 both extra', 'expected "cut SECONDS'),
    ('drop 0.2', 'expected "cut SECONDS'),
    ('lose 0.2 10', 'expected "cut SECONDS'),
    ('cut soon', "cut length 'soon' is not a number"),
    ('cut nan', 'not a finite number'),
    ('cut -1', 'cut length -1 s is outside 0..3600'),
    ('cut 4000', 'outside 0..3600'),
    ('drop 1.5 10', 'loss probability 1.5 is outside 0..1'),
    ('drop -0.1 10', 'outside 0..1'),
    ('drop inf 10', 'not a finite number'),
    ('drop 0.2 -3', 'drop length -3 s is outside'),
    ('drop 0.2 10 sideways', "unknown direction 'sideways'"),
    ('cut 2 up', "unknown direction 'up'"),
])
def test_bad_commands_say_why(text, reason):
    with pytest.raises(ValueError, match=reason.replace('(', r'\(').replace('.', r'\.')):
        parse_control(text)
