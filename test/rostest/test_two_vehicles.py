#!/usr/bin/env python3
"""Vehicles of multi_uav.launch at once: they take off together (~first: the first's id, 0; ~count: how many,
2; ~sim_nodes: the simulator nodes the launch must have started, e.g. its shared processes)."""

import os

import rospy
import rostest

from offboard_py.sim.main import vehicles_served
from offboard_py.testing.rostest_common import OffboardTestCase, Vehicle

PKG = 'offboard_py'
# offb_node's request spacing (the tutorial's 5 s): a vehicle that needed one request more than the other,
# or that waited for the other, arms this much later on its own schedule
REQUEST_INTERVAL_S = 5.0


def simulator_processes():
    """{node name: the instances it serves} of each simulator process roslaunch started for this master (the
    simulated PX4 speaks MAVLink, not ROS, so the master does not know it), from sim_px4.py's command line.
    Only this master's: /proc shows every process of the machine, those of other tests run in other network
    namespaces at the same time too (a run saw another test's sim_px4 -i 20 here)."""
    found = {}
    master = ('ROS_MASTER_URI=%s' % os.environ.get('ROS_MASTER_URI', '')).encode()
    for pid in filter(str.isdigit, os.listdir('/proc')):
        try:
            with open('/proc/%s/cmdline' % pid, 'rb') as f:
                argv = f.read().decode(errors='replace').split('\0')
            with open('/proc/%s/environ' % pid, 'rb') as f:
                if master not in f.read().split(b'\0'):
                    continue  # another master's
        except OSError:
            continue  # gone meanwhile
        names = [a.split(':=', 1)[1] for a in argv if a.startswith('__name:=')]
        script = [k for k, a in enumerate(argv) if a.endswith('sim_px4.py')]
        if names and script:
            found[names[0]] = list(vehicles_served(argv[script[0] + 1:]))
    return found


class TwoVehiclesTest(OffboardTestCase):

    def test_both_take_off(self):
        first, count = rospy.get_param('~first', 0), rospy.get_param('~count', 2)
        uavs = [Vehicle('uav%d/mavros' % (first + k)) for k in range(count)]
        for uav in uavs:
            self.wait_for_connected(uav, 30.0)
        expected = rospy.get_param('~sim_nodes', '').split()
        if expected:  # the simulator processes the launch was to start, by node name, and whom they serve
            running = simulator_processes()
            self.assertEqual(sorted(running), sorted(expected),
                             'the simulator processes running are not the ones the launch should have started')
            served = sorted(i for instances in running.values() for i in instances)
            self.assertEqual(served, list(range(first, first + count)),
                             'each vehicle should be served by exactly one simulator process: %s' % running)
        self.wait_for_offboard_and_armed(uavs, 60.0, 'all OFFBOARD and armed')
        # within 0.1 m before the +-0.15 m hold: PX4 creeps over the last decimetre to 2 m
        self.wait_until(lambda: all(abs(u.z() - 2.0) <= 0.1 for u in uavs), 30.0, 'all at 2 m', uavs)
        # Each node's schedule runs from its first setpoint (it streams once it sees the connection). The
        # stacks start a second or two apart in wall time, which simulated time at OFFBOARD_PY_SPEED
        # multiplies, so the arming times themselves may be 5 s apart; the time each node took from its
        # first setpoint to armed may not: that is the same tutorial schedule on independent stacks.
        unseen = [u.ns for u in uavs if not u.setpoints]
        if unseen:
            self.fail('no setpoint of offb_node seen on %s/setpoint_position/local: its schedule cannot be timed'
                      % ', '.join(unseen))
        started_at = [u.setpoints[0] for u in uavs]
        armed_at = [next(t for t, s in u.states if s.armed) for u in uavs]
        took = [a - s for a, s in zip(armed_at, started_at)]
        rospy.loginfo('first setpoint at %s, armed at %s: %s s from first setpoint to armed',
                      started_at, armed_at, ['%.2f' % t for t in took])
        self.assertLess(max(took) - min(took), REQUEST_INTERVAL_S,
                        'they should fly together, not one after the other: from its first setpoint to armed %s'
                        % ', '.join('%s took %.2f s' % (u.ns, t) for u, t in zip(uavs, took)))
        for uav in uavs:
            self.assert_holds(uav, 2.0, 0.15, 2.0)

if __name__ == '__main__':
    rospy.init_node('test_two_vehicles')
    rostest.rosrun(PKG, 'two_vehicles', TwoVehiclesTest)
