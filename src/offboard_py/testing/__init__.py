"""Test kit of offboard_py: test your own offboard node against the simulated PX4.

This package's own tests use it, and it is public for other packages (README, "Test your own
node"). What is public is what this module exports (`__all__`), importable from here:

rostest (a test node of yours beside the vehicle of sim_vehicle.launch; imports rospy):
  OffboardTestCase  unittest.TestCase with waits in ROS time that fail saying what they saw:
                    wait_for_connected, wait_for_mode, wait_for_armed, wait_for_offboard_and_armed,
                    wait_for_altitude, wait_for_position ("reached"), assert_holds and
                    assert_holds_position ("held"), wait_for_failsafe (the offboard-loss failsafe
                    timed from the node's last setpoint), wait_until, pause, set_mode, set_arm,
                    call_service; and the clock guard of simulated time, and late_s() (how late
                    a busy machine may let the test see a change, for the bounds of what it times)
  Vehicle           the mavros view of one vehicle namespace ('mavros', 'uav1/mavros'): state,
                    pose, and their histories (states, positions, poses, velocities in 3-D, and
                    setpoints / setpoint_history of every mavros setpoint topic: setpoint_values,
                    setpoint_counts); docs/testing.md, "What the test kit sees"
  RosoutRecorder    what one node logged, from /rosout
  now               ROS time in seconds (simulated seconds in simulated time)

failsafes (plain pymavlink, no ROS; in a rostest or a pytest alike):
  Failures          a ground station on the vehicle's GCS link that causes PX4's failsafes through
                    MAVLink only, so the same test drives real PX4 SITL: gps_off, battery_off,
                    set_battery(percent), cut_data_link, lose_rc (after start_joystick),
                    upload_fence / fence_circle, set_param, inject; and what PX4 said (texts,
                    modes, latest). docs/failsafes.md

pytest with plain pymavlink (no ROS):
  offboard_py.testing.pytest_plugin   fixtures sim_px4 and start_sim:
                                      pytest_plugins = ['offboard_py.testing.pytest_plugin']
  SimProcess, Client, start_simulated_px4   the simulated PX4 as a process on free ports, and a
                                      pymavlink client of it (offboard_py.testing.sim_client)

ports (no ROS): instance numbers and UDP ports, from one formula
  ports.fcu_port, ports.bridge_port, ports.system_id, ports.free_instances

The other modules here (processes, mavlink_listener, mavlink_fuzz, lossy_relay, mavros_typemasks,
broken_offb_node, example_workspace, cross_stack, and reference and measured_tables, which read the figures
of reference/) serve this package's own tests and may change without notice. Importing
this package imports neither rospy nor pymavlink: each name is imported when first used, so
the ROS-free tiers never load rospy.
"""

import importlib

from offboard_py.testing import ports

_LAZY = {
    'OffboardTestCase': 'rostest_common',
    'Vehicle': 'rostest_common',
    'RosoutRecorder': 'rostest_common',
    'now': 'rostest_common',
    'Failures': 'failures',
    'SimProcess': 'sim_client',
    'Client': 'sim_client',
    'start_simulated_px4': 'sim_client',
}

__all__ = sorted(_LAZY) + ['ports']


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError('module %r has no attribute %r' % (__name__, name))
    value = getattr(importlib.import_module('offboard_py.testing.' + module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
