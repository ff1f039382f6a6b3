"""Which stack flies: the FCU (`fcu:=sim|px4_sih`) and the ROS side (`bridge:=ours|mavros`).

The launch files take these two arguments; `sim` and `ours` are this project's simulated PX4 and
mavros-compatible bridge, `px4_sih` a real PX4 SITL with PX4's SIH quadrotor (offboard_py.px4_sih),
`mavros` real mavros's px4.launch. This module names the choices once, says in one line what is
wrong with a choice (`python -m offboard_py.stack fcu:=... bridge:=...`, run by the launch files
when an argument has no such value, exits 1 and so ends the launch), and finds the real parts a
user has built (`find_real_parts`, for the cross-stack test tier; `rospack_find`, also for
`./run bench --replay --compare`).
"""

import os
import subprocess
import sys

from offboard_py import px4_sih

FCUS = {'sim': 'our simulated PX4', 'px4_sih': 'real PX4 SITL (SIH quadrotor)'}
BRIDGES = {'ours': 'our mavros-compatible bridge', 'mavros': 'real mavros'}
CONFIG_FILE = 'real-stack.conf'  # beside ./run: PX4_DIR=... (one NAME=value a line, # comments)


def describe(fcu, bridge):
    """'our bridge + real PX4 SITL (SIH quadrotor)'-style label of a stack, for plots and tables."""
    return '%s + %s' % (BRIDGES.get(bridge, bridge), FCUS.get(fcu, fcu))


SIM_PROCESSES = {'each': 'a simulator process a vehicle',
                 'one': 'shared simulator processes, one loop for up to vehicles_per_sim vehicles each'}
# multi_uav.launch's vehicles_per_sim: a simulator process runs on one core, and on the 2-core development
# machine one process of 32 vehicles fell behind its clock beside the fleet's ROS side where two of 16 did not
# (bench/results/2026-11-26-fleet-stalls.md)
VEHICLES_PER_SIM = 16


def choice_errors(fcu, bridge, sim_process='each', vehicles_per_sim=str(VEHICLES_PER_SIM)):
    """What is wrong with the launch arguments fcu, bridge, sim_process and vehicles_per_sim, one line each
    (none: nothing)."""
    errors = []
    if sim_process not in SIM_PROCESSES:
        errors.append('sim_process:=%s is not a way to run the simulated vehicles: use %s'
                      % (sim_process, ' or '.join('sim_process:=%s (%s)' % kv for kv in SIM_PROCESSES.items())))
    if not (vehicles_per_sim.isdigit() and int(vehicles_per_sim) > 0):
        errors.append('vehicles_per_sim:=%s is not a number of vehicles: give a whole number from 1 (default %d)'
                      % (vehicles_per_sim, VEHICLES_PER_SIM))
    if fcu not in FCUS:
        errors.append('fcu:=%s is not a flight controller this launch can start: use %s'
                      % (fcu, ' or '.join('fcu:=%s (%s)' % kv for kv in FCUS.items())))
    if bridge not in BRIDGES:
        errors.append('bridge:=%s is not a ROS side this launch can start: use %s'
                      % (bridge, ' or '.join('bridge:=%s (%s)' % kv for kv in BRIDGES.items())))
    return errors


def read_config(path):
    """NAME=value lines of a real-stack config file ({} when there is none); bad lines raise ValueError."""
    values = {}
    if not os.path.exists(path):
        return values
    with open(path) as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith('#'):
                continue
            name, sep, value = line.partition('=')
            if not sep or not name.strip():
                raise ValueError('%s:%d: expected NAME=value, got %r' % (path, number, line))
            values[name.strip()] = os.path.expanduser(value.strip())
    return values


def in_setup(cmd, setup=None):
    """cmd run in the environment a setup.bash makes (a workspace's devel/setup.bash; None: this one)."""
    return list(cmd) if setup is None else ['bash', '-c', 'source "$0" && exec "$@"', setup] + list(cmd)


def rospack_find(package, setup=None):
    """The package's folder, or None when ROS cannot find it (in this environment, or in setup's)."""
    try:
        out = subprocess.run(in_setup(['rospack', 'find', package], setup), stdout=subprocess.PIPE,
                             stderr=subprocess.DEVNULL, universal_newlines=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def find_real_parts(env=None, config_path=None, find_package=None):
    """{'px4_dir': DIR or None, 'mavros': DIR or None, 'why': [lines saying what was not found]}.
    PX4: $PX4_DIR, else PX4_DIR in the config file; mavros: `rospack find mavros`."""
    env = os.environ if env is None else env
    find_package = rospack_find if find_package is None else find_package
    config = read_config(config_path) if config_path else {}
    px4_dir = env.get('PX4_DIR') or config.get('PX4_DIR') or ''
    found = {'px4_dir': None, 'mavros': None, 'why': []}
    try:
        px4_sih.find_build(px4_dir)
        found['px4_dir'] = os.path.abspath(os.path.expanduser(px4_dir))
    except px4_sih.MissingPx4 as err:
        found['why'].append('no real PX4: %s' % err)
    found['mavros'] = find_package('mavros')
    if not found['mavros']:
        found['why'].append('no real mavros: `rospack find mavros` finds no package')
    return found


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    given = dict(a.split(':=', 1) for a in argv if ':=' in a and not a.startswith('__'))
    errors = choice_errors(given.get('fcu', 'sim'), given.get('bridge', 'ours'), given.get('sim_process', 'each'),
                           given.get('vehicles_per_sim', str(VEHICLES_PER_SIM)))
    for line in errors:
        print('error: %s' % line, file=sys.stderr)
    return 1 if errors else 0


if __name__ == '__main__':
    sys.exit(main())
