"""Frame conventions (as mavros's ftf) and the PX4 mode table, offline."""

import math
import os

import pytest

from offboard_py import frames, px4_modes
from offboard_py.dialect import mavlink
from offboard_py.testing import measured_tables

CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED


def test_position_enu_ned_swap():
    assert frames.enu_to_ned(1.0, 2.0, 3.0) == (2.0, 1.0, -3.0)
    assert frames.ned_to_enu(*frames.enu_to_ned(1.0, 2.0, 3.0)) == (1.0, 2.0, 3.0)
    assert frames.flu_to_frd(1.0, 2.0, 3.0) == (1.0, -2.0, -3.0)


@pytest.mark.parametrize('yaw_enu, yaw_ned', [(0.0, math.pi / 2), (math.pi / 2, 0.0), (math.pi, -math.pi / 2),
                                              (-math.pi / 2, math.pi)])
def test_yaw_conversion(yaw_enu, yaw_ned):
    assert frames.yaw_enu_to_ned(yaw_enu) == pytest.approx(yaw_ned)
    # the orientation path gives the same yaw as the shortcut
    q_ned = frames.orientation_enu_to_ned(frames.quaternion_from_yaw(yaw_enu))
    assert math.cos(frames.quaternion_yaw(q_ned) - yaw_ned) == pytest.approx(1.0)


def test_orientation_round_trip_with_roll_and_pitch():
    q = (0.1, -0.2, 0.3, 0.927)
    n = math.sqrt(sum(c * c for c in q))
    q = tuple(c / n for c in q)
    back = frames.orientation_ned_to_enu(frames.orientation_enu_to_ned(q))
    assert abs(sum(a * b for a, b in zip(q, back))) == pytest.approx(1.0)


def test_zero_quaternion_faces_east_like_mavros():
    """The tutorial streams an all-zero quaternion; mavros's Eigen makes it the identity (ENU yaw 0,
    facing east), which is NED yaw +90 deg."""
    assert frames.pose_rotation((0.0, 0.0, 0.0, 0.0)) == (0.0, 0.0, 0.0, 1.0)
    yaw = frames.quaternion_yaw(frames.orientation_enu_to_ned(frames.pose_rotation((0.0, 0.0, 0.0, 0.0))))
    assert yaw == pytest.approx(math.pi / 2)


# Quaterniond(Affine3d(Translation3d(1, 2, 3) * Quaterniond(w, x, y, z)).rotation()) from Eigen 3.4, as
# mavros 1.21 computes it, for orientations (x, y, z, w) that are not unit quaternions
EIGEN_ROTATIONS = [
    ((0.0, 0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0)),
    ((0.0, 0.0, 0.5, 0.5), (0.0, 0.0, 0.38268343236508978, 0.92387953251128674)),  # 45 deg, not 90
    ((0.0, 0.0, 2.0, 0.0), (0.0, 0.0, 1.0, 0.0)),
    ((0.0, 0.0, 0.7, 0.0), (0.0, 0.0, 0.0, 1.0)),                                     # |v|^2 < 1/2: none
    ((0.2, -0.3, 0.4, 1.5), (0.22718520408637655, -0.34077780612956476, 0.45437040817275298, 0.79107831601597967)),
    ((0.3, 0.1, -0.2, 0.25), (0.10163879135580965, 0.033879597118603222, -0.06775919423720643, 0.99193266938191726)),
    ((0.5, 0.5, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),                                     # the singular case
]


@pytest.mark.parametrize('q, expected', EIGEN_ROTATIONS)
def test_pose_rotation_is_eigens(q, expected):
    got = frames.pose_rotation(q)
    assert got == pytest.approx(expected, abs=1e-12) or tuple(-c for c in got) == pytest.approx(expected, abs=1e-12)


def test_pose_rotation_leaves_unit_quaternions_as_they_are():
    q = (0.1, -0.2, 0.3, 0.927)
    n = math.sqrt(sum(c * c for c in q))
    q = tuple(c / n for c in q)
    assert frames.pose_rotation(q) is q


def test_wrap_pi():
    assert frames.wrap_pi(3 * math.pi) == pytest.approx(math.pi)
    assert frames.wrap_pi(-3 * math.pi / 2) == pytest.approx(math.pi / 2)


def test_rotate():
    x, y, z = frames.rotate(frames.quaternion_from_yaw(math.pi / 2), (1.0, 0.0, 0.0))
    assert (x, y, z) == pytest.approx((0.0, 1.0, 0.0))


@pytest.mark.parametrize('mode, main, sub', [('MANUAL', 1, 0), ('ALTCTL', 2, 0), ('POSCTL', 3, 0), ('ACRO', 5, 0),
                                             ('OFFBOARD', 6, 0), ('STABILIZED', 7, 0), ('RATTITUDE', 8, 0),
                                             ('AUTO.READY', 4, 1), ('AUTO.TAKEOFF', 4, 2), ('AUTO.LOITER', 4, 3),
                                             ('AUTO.MISSION', 4, 4), ('AUTO.RTL', 4, 5), ('AUTO.LAND', 4, 6),
                                             ('AUTO.RTGS', 4, 7), ('AUTO.FOLLOW_TARGET', 4, 8),
                                             ('AUTO.PRECLAND', 4, 9)])
def test_mode_table(mode, main, sub):
    custom = (main << 16) | (sub << 24)
    assert px4_modes.encode(mode) == custom
    assert px4_modes.mode_string(CUSTOM, custom) == mode


def test_mode_strings_for_odd_heartbeats():
    assert px4_modes.encode('AUTO.LOITER') == 50593792  # what PX4 SITL boots in
    assert px4_modes.mode_string(CUSTOM, 4 << 16) == 'AUTO.MISSION'  # AUTO without sub-mode
    assert px4_modes.mode_string(CUSTOM, 99 << 16) == 'CMODE(%d)' % (99 << 16)
    assert px4_modes.mode_string(0x5C, 0) == 'MODE(0x5C)'
    assert px4_modes.mode_string(0x08, 0) == 'MODE(0x 8)'


def test_base_mode_flags_as_px4():
    assert px4_modes.base_mode_flags('OFFBOARD', True) == 145
    assert px4_modes.base_mode_flags('AUTO.LOITER', False) == 29
    assert px4_modes.base_mode_flags('POSCTL', False) == 1 | 16 | 64
    assert px4_modes.base_mode_flags('ACRO', True) == 1 | 64 | 128


# -- AVAILABLE_MODES: the table PX4 SITL answered (reference/px4-sitl-measured.md, section 3) ----------

MEASURED = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__)))),
                        'reference', 'px4-sitl-measured.md')


def recorded_available_modes():
    """[(mode_index, custom_mode, PX4 mode, standard_mode, properties, mode_name)] from the recording's table."""
    return measured_tables.available_modes(MEASURED)


def test_available_modes_are_px4_sitls_26_in_its_order():
    recorded = recorded_available_modes()
    assert [r[0] for r in recorded] == list(range(1, 27)), 'the recording: mode_index 1..26'
    ours = [(i, m.custom_mode, m.label, m.standard_mode, m.properties, m.mode_name)
            for i, m in enumerate(px4_modes.AVAILABLE_MODES, 1)]
    assert ours == recorded
    assert all((m.standard_mode == 0) == bool(m.mode_name) for m in px4_modes.AVAILABLE_MODES), \
        'mode_name empty exactly where standard_mode is not 0'


def test_current_mode_standard_mode_follows_the_table():
    by_label = {r[2]: r for r in recorded_available_modes()}
    for label in ('AUTO.LOITER', 'OFFBOARD', 'AUTO.RTL', 'AUTO.LAND', 'AUTO.TAKEOFF', 'AUTO.MISSION', 'POSCTL'):
        assert px4_modes.standard_mode(px4_modes.encode(label)) == by_label[label][3], label
    assert px4_modes.standard_mode(0x7F0000) == 0, 'a mode PX4 does not list is non-standard'
