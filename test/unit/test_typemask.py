"""A NaN in a setpoint field is refused only where the type_mask says PX4 uses it."""

from offboard_py.bridge.typemask import POSITION_YAW, bad_used_fields

NAN, INF = float('nan'), float('inf')
VELOCITY_ONLY = 1 | 2 | 4 | 64 | 128 | 256 | 1024 | 2048   # what a velocity-control client sends


def values(**changes):
    base = {name: 0.0 for name in ('position.x', 'position.y', 'position.z', 'velocity.x', 'velocity.y',
                                   'velocity.z', 'acceleration_or_force.x', 'acceleration_or_force.y',
                                   'acceleration_or_force.z', 'yaw', 'yaw_rate')}
    base.update({k.replace('__', '.'): v for k, v in changes.items()})
    return base


def test_nan_in_ignored_fields_is_fine():
    assert bad_used_fields(VELOCITY_ONLY, values(position__x=NAN, position__z=INF, yaw=NAN)) == []
    assert bad_used_fields(POSITION_YAW, values(velocity__x=NAN, yaw_rate=NAN)) == []


def test_nan_in_used_fields_is_named():
    assert bad_used_fields(VELOCITY_ONLY, values(velocity__z=NAN)) == ['velocity.z']
    assert bad_used_fields(POSITION_YAW, values(position__y=INF, yaw=NAN)) == ['position.y', 'yaw']
    assert bad_used_fields(0, values(acceleration_or_force__x=-INF)) == ['acceleration_or_force.x']


def test_position_yaw_is_what_mavros_setpoint_position_sends():
    assert POSITION_YAW == 0x9F8
