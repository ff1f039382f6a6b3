"""The takeoff scenario must fail for a node that does not stream first, and say why.

Runs the real rostest (its own master, a free instance) with test/rostest/broken_offb_node.py as
the node under test and reads the JUnit result it writes.
"""

import os
import subprocess
import tempfile
import xml.etree.ElementTree as ET

from offboard_py.testing.ports import free_instances


def takeoff_failures(*launch_args):
    """Run takeoff.test on a free instance with launch_args; the text of its JUnit failures ('' if none)."""
    instance, = free_instances(1)
    with tempfile.TemporaryDirectory() as results:
        out = subprocess.run(['rostest', '--results-base-dir', results, 'offboard_py', 'takeoff.test',
                              'instance:=%d' % instance] + list(launch_args),
                             capture_output=True, text=True, timeout=240)
        files = [os.path.join(d, f) for d, _, fs in os.walk(results) for f in fs if f.startswith('rosunit-')]
        assert files, 'no result file; rostest said:\n' + out.stdout[-3000:] + out.stderr[-3000:]
        failures = [node for f in files for node in ET.parse(f).getroot().iter('failure')]
    return ' '.join((node.get('message') or '') + (node.text or '') for node in failures)


def test_takeoff_scenario_fails_for_a_node_without_prestream():
    # at 2x, not ./run test's 5x: this runs beside the simulator tier, and at 5x a 0.1 s stall of the machine
    # trips the clock guard (0.51 s simulated, once in CI on 2026-11-25), a verdict on the machine, not the node
    message = takeoff_failures('node_type:=broken_offb_node.py', 'deadline:=25', 'speed:=2')
    assert message, 'the takeoff scenario passed with a broken node'
    assert 'OFFBOARD and armed did not happen' in message, message
    assert 'setpoints streamed by the node: 0' in message, message
    assert 'disarmed' in message, message


def test_a_machine_that_cannot_keep_up_fails_the_scenario_saying_so():
    """When the ROS side falls behind the vehicles' clock (a machine that cannot keep up at the speed),
    the scenario fails on the clock guard, naming the lag and the speed, rather than on a failsafe.
    The lag is injected (sim_clock's fault_lag: /clock 2 s behind at 5x), so this holds on any machine."""
    message = takeoff_failures('speed:=5', 'clock_fault_lag:=2.0')
    assert message, 'the takeoff scenario passed with /clock 2 s behind the vehicles: the guard did not fire'
    assert "behind the vehicles' clock at 5x" in message and 'cannot keep up' in message, message
