"""multi_uav.launch's simulator processes, as roslaunch itself reads the file (its XML loader, no launch):
sim_process:=one shares a process among at most vehicles_per_sim vehicles, each vehicle in exactly one."""

import os

import pytest
import roslaunch.config

from offboard_py import stack
from offboard_py.sim.main import vehicles_served

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
MULTI_UAV = os.path.join(REPO, 'launch', 'multi_uav.launch')


def nodes(*args):
    config = roslaunch.config.load_config_default([(MULTI_UAV, list(args))], None, verbose=False)
    return config.nodes


def simulators(*args):
    """(name, instances served, spawn argument, required) of each simulator node of the launch."""
    found = []
    for node in nodes(*args):
        if node.type != 'sim_px4.py':
            continue
        argv = node.args.split()
        found.append((node.namespace + node.name, list(vehicles_served(argv)), argv[argv.index('--spawn') + 1],
                      node.required))
    return found


@pytest.mark.parametrize('n', [1, 2, 16, 17, 32, 33])
def test_each_vehicle_is_in_one_shared_process_of_at_most_vehicles_per_sim(n):
    sims = simulators('n:=%d' % n, 'sim_process:=one')
    per = stack.VEHICLES_PER_SIM
    assert sorted(i for _, served, _, _ in sims for i in served) == list(range(n))
    assert all(len(served) <= per for _, served, _, _ in sims)
    assert len(sims) == -(-n // per)
    assert all(required for *_, required in sims), 'a fleet whose simulator died must end'
    # the first keeps the name it had when one process served them all; each spawns its first vehicle where
    # uav_chain.launch places that vehicle (3 m apart along y), so the places are as with a process each
    assert sims[0][0] == '/sim_px4' and [name for name, *_ in sims[1:]] == ['/sim_px4_%d' % (k * per)
                                                                           for k in range(1, len(sims))]
    assert [spawn for _, _, spawn, _ in sims] == ['0,%d' % (3 * served[0]) for _, served, _, _ in sims]


def test_a_fleet_from_another_first_id_counts_its_groups_from_there():
    sims = simulators('n:=7', 'first:=16', 'sim_process:=one', 'vehicles_per_sim:=3', 'sim_args:=--ideal')
    assert [(name, served) for name, served, _, _ in sims] == [
        ('/sim_px4', [16, 17, 18]), ('/sim_px4_19', [19, 20, 21]), ('/sim_px4_22', [22])]
    assert all('--ideal' in node.args for node in nodes('n:=7', 'first:=16', 'sim_process:=one', 'sim_args:=--ideal')
               if node.type == 'sim_px4.py')


def test_a_process_each_and_real_px4_start_no_shared_simulator():
    each = simulators('n:=3')
    assert [(name, served) for name, served, _, _ in each] == [('/uav%d/sim_px4' % i, [i]) for i in range(3)]
    assert not [node for node in nodes('n:=2', 'sim_process:=one', 'fcu:=px4_sih') if node.type == 'sim_px4.py']


@pytest.mark.parametrize('bad', ['0', 'abc', '-1'])
def test_a_bad_vehicles_per_sim_starts_the_check_that_names_it_and_no_simulator(bad):
    launched = nodes('n:=3', 'sim_process:=one', 'vehicles_per_sim:=%s' % bad)
    checks = [node for node in launched if node.type == 'stack_check.py']
    assert len(checks) == 1 and checks[0].required and 'vehicles_per_sim:=%s' % bad in checks[0].args
    assert stack.main(checks[0].args.split()) == 1
    assert not [node for node in launched if node.type == 'sim_px4.py']
