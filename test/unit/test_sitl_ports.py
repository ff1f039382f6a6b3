"""One port formula for code, launch files and tests: PX4 SITL's (offboard_py.sitl_ports).

roslaunch cannot import Python, so the launch files and the .test files spell the formula in
$(eval ...). Every such expression that computes a port or an fcu_url is evaluated here, as roslaunch
would, for each instance, and must give what offboard_py.sitl_ports (and the tests' extra-port block
of offboard_py.testing.ports) gives: a base changed in one place and not in the other fails here.
"""

import glob
import os
import re

import pytest

from offboard_py import sitl_ports
from offboard_py.testing import ports

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
FILES = sorted(glob.glob(os.path.join(REPO, 'launch', '*.launch')) +
               glob.glob(os.path.join(REPO, 'test', 'rostest', '*.test')))
EVAL = re.compile(r"\$\(eval (.*?)\)\"")


def port_expressions():
    found = []
    for path in FILES:
        with open(path) as f:
            for expression in EVAL.findall(f.read()):
                if re.search(r'\b1454\d|\b1458\d|\b15000\b', expression):
                    found.append((os.path.relpath(path, REPO), expression))
    return found


def evaluate(expression, instance):
    values = {'instance': str(instance), 'ID': str(instance)}
    return eval(expression, {'__builtins__': {'int': int, 'float': float, 'str': str}},  # noqa: S307 (our own files)
                {'arg': values.__getitem__})


def test_the_launch_files_spell_the_formula_somewhere():
    places = {path for path, _ in port_expressions()}
    assert 'launch/sim_vehicle.launch' in places and len(places) >= 5, sorted(places)


@pytest.mark.parametrize('path, expression', port_expressions())
def test_every_spelling_gives_the_formulas_ports(path, expression):
    for instance in (0, 1, 7, 10, 19, 39):
        value = evaluate(expression, instance)
        if isinstance(value, str):
            assert value == sitl_ports.fcu_url(instance), '%s: %s gives %r for instance %d' % (
                path, expression, value, instance)
        elif value >= ports.EXTRA_PORT_BASE:
            k = value - ports.extra_port(instance, 0)
            assert 0 <= k < ports.EXTRA_PORTS_PER_INSTANCE and value == ports.extra_port(instance, k), \
                '%s: %s gives %d for instance %d, not in its extra block' % (path, expression, value, instance)
        else:
            assert value in (sitl_ports.fcu_port(instance), sitl_ports.bridge_port(instance)), \
                '%s: %s gives %d for instance %d' % (path, expression, value, instance)


def test_no_two_roles_or_instances_share_a_port_and_no_bridge_takes_the_ground_stations():
    """Instances 0-39 (what the tests and fleets use): every FCU, bridge and GCS port is its own, and
    no bridge binds 14550, where every FCU's GCS link sends (a bridge there took in the whole fleet's
    GCS streams: 15 % of a core at 32 vehicles)."""
    owners = {}
    for instance in range(40):
        for role, port in (('fcu', sitl_ports.fcu_port(instance)), ('bridge', sitl_ports.bridge_port(instance)),
                           ('gcs', sitl_ports.gcs_port(instance))):
            assert port not in owners, 'port %d: %s of instance %d and %s of instance %d' % (
                (port, role, instance) + owners[port])
            owners[port] = (role, instance)
    assert sitl_ports.GCS_REMOTE_PORT not in owners, owners.get(sitl_ports.GCS_REMOTE_PORT)
    assert sitl_ports.fcu_url(10) == 'udp://:14620@localhost:14590'
    assert sitl_ports.fcu_url(9) == 'udp://:14549@localhost:14589'  # PX4's 14540+N below 10


def test_the_simulator_binds_and_numbers_as_the_formula():
    from offboard_py.sim.autopilot import SimulatedPx4
    sim = SimulatedPx4(instance=39, gcs=True, gcs_remote_port=9)  # 39: no automated test flies it
    try:
        assert sim.system_id == sitl_ports.system_id(39)
        assert sim.link.bind[1] == sitl_ports.fcu_port(39) and sim.link.remote[1] == sitl_ports.bridge_port(39)
        assert sim.gcs_link.bind[1] == sitl_ports.gcs_port(39)
    finally:
        sim.close_links()


@pytest.mark.parametrize('path', FILES, ids=lambda p: os.path.relpath(p, REPO))
def test_launch_and_test_files_are_well_formed_xml(path):
    """roslaunch refuses a file that is not XML (a '--' in a comment is enough) only when it is launched:
    a fleet size or a scenario nobody ran would fail on a user's machine first."""
    import xml.dom.minidom
    xml.dom.minidom.parse(path)
