"""The simulated PX4's navigator is a package with one module per mode, as PX4's src/modules/navigator has
one file per mode; what its importers take from offboard_py.sim.navigator stays there."""

import importlib

import offboard_py.sim.navigator as navigator

MODULE_OF = {'NavigatorMode': 'navigator_mode', 'Loiter': 'loiter', 'Takeoff': 'takeoff', 'Land': 'land',
             'Rtl': 'rtl', 'MissionMode': 'mission', 'FollowTargetMode': 'follow_target'}


def test_each_mode_is_in_its_own_module_and_importable_from_the_package():
    for name, module in MODULE_OF.items():
        cls = getattr(importlib.import_module('offboard_py.sim.navigator.' + module), name)
        assert getattr(navigator, name) is cls
        assert cls.__module__ == 'offboard_py.sim.navigator.' + module
        assert cls is navigator.NavigatorMode or issubclass(cls, navigator.NavigatorMode)


def test_the_navigator_stays_in_the_package():
    assert navigator.Navigator.__module__ == 'offboard_py.sim.navigator'
    assert navigator.GIMBAL_DELAY_S == 0.25
