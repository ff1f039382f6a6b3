"""The cross-stack test tier: the rostest scenarios that mean the same on real PX4 and real mavros,
flown on the real parts a user has built, beside ours.

Columns: our bridge + real PX4 SITL (SIH), real mavros + our simulator, real mavros + real PX4 SITL.
A column runs when its real parts are found (offboard_py.stack.find_real_parts: $PX4_DIR or
PX4_DIR in real-stack.conf beside ./run; mavros by `rospack find mavros`); a scenario that cannot
mean the same on a column (a fault only our simulator injects, a process only ours is) is skipped
there with its reason. The scenarios' assertions are unchanged: they get `fcu:=`, `bridge:=` and
`px4_dir:=` and fly in real time (PX4 SITL's clock is its own). Each run's JUnit file goes into the
results folder as cross-<scenario>-<column>.xml, so catkin_test_results counts it with the rest, and
the tier ends with a matrix (scenario x column: passed, failed, skipped). Without any real part it
prints one line saying so and runs nothing.

The example packages' tests (examples/, offboard_py.testing.example_workspace) are rows too, flown as a
user flies them on real PX4: built in a workspace chained on ours, their .test files unchanged, the stack
chosen by OFFBOARD_PY_FCU, OFFBOARD_PY_BRIDGE and PX4_DIR alone (docs/testing.md).

    python -m offboard_py.testing.cross_stack --results DIR [--config FILE] [--dry-run]
"""

import argparse
import collections
import glob
import os
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ElementTree

from offboard_py import stack
from offboard_py.testing import example_workspace

PKG = 'offboard_py'
Column = collections.namedtuple('Column', 'name fcu bridge')
COLUMNS = (Column('bridge+px4', 'px4_sih', 'ours'),
           Column('mavros+sim', 'sim', 'mavros'),
           Column('mavros+px4', 'px4_sih', 'mavros'))
# scenario -> (its .test file, the SITL instance it flies as, {column name: why it is skipped there}
# or a reason it is skipped on every column)
ALL = object()
SIH_NO_GPS_FAILURE = ('PX4 SITL SIH has no SimulatorMavlink, the module that takes MAV_CMD_INJECT_FAILURE for GPS: '
                      'recorded, no COMMAND_ACK and no reaction in 60 s, where the simulated PX4 stands for PX4 SITL '
                      'with Gazebo Classic (the GPS stops, EKF2 gives the position up)')
SCENARIOS = collections.OrderedDict([
    ('takeoff', ('takeoff.test', 4, {})),
    ('offboard_loss', ('offboard_loss.test', 7, {})),
    ('stream_rate', ('stream_rate.test', 5, {})),
    ('respect_pilot', ('respect_pilot.test', 2, {})),
    ('late_fcu', ('late_fcu.test', 8, {})),
    ('restarts', ('restarts.test', 12, {ALL: 'kills our simulator by its process name (sim_px4.py -i N) and has it '
                                             'respawned, with our bridge\'s conn/timeout at 3 s: real PX4 (px4_sih.py, '
                                             'required, never respawned) and mavros\'s px4.launch (conn/timeout from '
                                             'its own config) are not yet written for'})),
    ('mission', ('mission.test', 17, {})),
    ('position_square', ('position_square.test', 18, {})),
    # the failsafes: PX4 SITL SIH has battery_simulator, the data link, the geofence and MAVLink manual control
    # as the simulated PX4 (which stands for PX4 SITL with Gazebo Classic); it has no SimulatorMavlink, which
    # takes the sensor failures (reference/px4-sitl-measured.md, "Turn 4 recordings", item 6)
    ('failsafe_battery', ('failsafe_battery.test', 16, {})),
    ('failsafe_data_link', ('failsafe_data_link.test', 22, {})),
    ('failsafe_geofence', ('failsafe_geofence.test', 23, {})),
    ('failsafe_gps', ('failsafe_gps.test', 24, {
        'bridge+px4': SIH_NO_GPS_FAILURE, 'mavros+px4': SIH_NO_GPS_FAILURE})),
    ('failsafe_rc', ('failsafe_rc.test', 25, {})),
    ('failsafe_offboard', ('failsafe_offboard.test', 26, {})),
])
# the example packages' tests: row name -> (package, .test file, instance)
EXAMPLES = collections.OrderedDict(('example:%s/%s' % (package, test_file[:-len('.test')]),
                                    (package, test_file, instance))
                                   for package, test_file, instance in example_workspace.TESTS)
TIME_LIMIT_S = 600.0  # one rostest run, real time, real PX4 starting included


def columns_found(found):
    """The columns whose real parts are all there."""
    have = {'px4_sih': bool(found['px4_dir']), 'mavros': bool(found['mavros'])}
    return [c for c in COLUMNS if (c.fcu == 'sim' or have['px4_sih']) and (c.bridge == 'ours' or have['mavros'])]


def plan(found):
    """[(scenario, column, reason or None)] for every scenario and column: None runs it."""
    runnable = {c.name for c in columns_found(found)}
    rows = []
    for scenario, (_, _, skips) in list(SCENARIOS.items()) + [(name, (None, None, {})) for name in EXAMPLES]:
        for column in COLUMNS:
            if column.name not in runnable:
                reason = 'its real parts are not installed here'
            else:
                reason = skips.get(ALL) or skips.get(column.name)
            rows.append((scenario, column, reason))
    return rows


def junit_outcome(path):
    """'passed' or 'failed' from a JUnit file (rostest's): any failure or error fails it."""
    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError):
        return 'failed'
    suites = [root] if root.tag == 'testsuite' else list(root.iter('testsuite'))
    bad = sum(int(s.get('failures', 0)) + int(s.get('errors', 0)) for s in suites)
    tests = sum(int(s.get('tests', 0)) for s in suites)
    return 'passed' if tests and not bad else 'failed'


def run_scenario(scenario, column, found, results_dir):
    test_file, instance, _ = SCENARIOS[scenario]
    out = tempfile.mkdtemp(prefix='cross-stack-')
    args = ['rostest', '--results-base-dir', out, PKG, test_file, 'instance:=%d' % instance,
            'fcu:=%s' % column.fcu, 'bridge:=%s' % column.bridge, 'px4_dir:=%s' % (found['px4_dir'] or '')]
    env = dict(os.environ, OFFBOARD_PY_SPEED='1')
    try:
        subprocess.run(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, timeout=TIME_LIMIT_S)
    except subprocess.TimeoutExpired:
        pass  # no JUnit file: failed
    files = glob.glob(os.path.join(out, PKG, '*.xml'))
    outcome = 'failed'
    for path in files:
        outcome = junit_outcome(path)
        shutil.copy(path, os.path.join(results_dir, 'cross-%s-%s.xml' % (scenario, column.name)))
    shutil.rmtree(out, ignore_errors=True)
    return outcome


def run_example(name, column, found, results_dir, setup_bash):
    """One example test as a user runs it on this column's stack: the variables choose it, the .test is as is."""
    package, test_file, instance = EXAMPLES[name]
    env = {'OFFBOARD_PY_FCU': column.fcu, 'OFFBOARD_PY_BRIDGE': column.bridge, 'PX4_DIR': found['px4_dir'] or '',
           'OFFBOARD_PY_SPEED': '1'}
    out = tempfile.mkdtemp(prefix='cross-stack-')
    try:
        example_workspace.run_rostest(setup_bash, package, test_file, ['instance:=%d' % instance], env=env,
                                      results_dir=out, timeout_s=TIME_LIMIT_S)
    except example_workspace.Timeout:
        pass  # its JUnit file, if any, says how far it came
    files = [os.path.join(d, f) for d, _, fs in os.walk(out) for f in fs if f.startswith('rosunit-')]
    outcome = 'failed'
    for path in files:
        outcome = junit_outcome(path)
        shutil.copy(path, os.path.join(results_dir, 'cross-%s-%s-%s.xml' % (package, test_file[:-len('.test')],
                                                                            column.name)))
    shutil.rmtree(out, ignore_errors=True)
    return outcome


def build_examples(workspace):
    """The example packages built in `workspace` chained on ours; its setup.bash, or None saying why not."""
    try:
        code, output, setup_bash = example_workspace.build(workspace)
    except example_workspace.Timeout as err:
        print('cross-stack tier: %s' % err)
        return None
    if code != 0:
        print('cross-stack tier: the example packages did not build:\n%s' % output[-3000:])
        return None
    return setup_bash


def matrix(outcomes):
    """The tier's closing table: a row per scenario and example test, a column per stack."""
    rows = list(SCENARIOS) + list(EXAMPLES)
    width = max(len(s) for s in rows)
    lines = ['%-*s  %s' % (width, 'scenario', '  '.join('%-12s' % c.name for c in COLUMNS))]
    for scenario in rows:
        lines.append('%-*s  %s' % (width, scenario, '  '.join('%-12s' % outcomes[scenario, c.name] for c in COLUMNS)))
    return '\n'.join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(prog='cross_stack', description=__doc__.split('\n\n')[0])
    p.add_argument('--results', required=True, help='the folder catkin_test_results reads')
    p.add_argument('--config', help='real-stack.conf (PX4_DIR=...)')
    p.add_argument('--dry-run', action='store_true', help='print the plan, run nothing')
    p.add_argument('--only', action='append', choices=list(SCENARIOS) + list(EXAMPLES), metavar='SCENARIO',
                   help='run this scenario only (repeatable; default: all of %s)'
                   % ', '.join(list(SCENARIOS) + list(EXAMPLES)))
    args = p.parse_args(argv)
    try:
        found = stack.find_real_parts(config_path=args.config)
    except ValueError as err:
        print('cross-stack tier: %s' % err, file=sys.stderr)
        return 2
    if not columns_found(found):
        print('cross-stack tier: skipped: %s' % '; '.join(found['why']))
        return 0
    os.makedirs(args.results, exist_ok=True)
    outcomes, skipped, built = {}, [], {}
    workspace = tempfile.mkdtemp(prefix='cross-stack-examples-')
    for scenario, column, reason in plan(found):
        if args.only and scenario not in args.only:
            outcomes[scenario, column.name] = 'not asked'
            continue
        if reason:
            outcomes[scenario, column.name] = 'skipped'
            skipped.append('%s on %s: %s' % (scenario, column.name, reason))
            continue
        if args.dry_run:
            outcomes[scenario, column.name] = 'would run'
            continue
        print('cross-stack tier: %s on %s ...' % (scenario, column.name), flush=True)
        if scenario in SCENARIOS:
            outcomes[scenario, column.name] = run_scenario(scenario, column, found, args.results)
            continue
        if 'setup_bash' not in built:
            built['setup_bash'] = build_examples(workspace)  # once, for every example row
        outcomes[scenario, column.name] = (run_example(scenario, column, found, args.results, built['setup_bash'])
                                           if built['setup_bash'] else 'failed')
    shutil.rmtree(workspace, ignore_errors=True)
    print('cross-stack tier (PX4: %s; mavros: %s):' % (found['px4_dir'] or 'not found', found['mavros'] or 'not found'))
    print(matrix(outcomes))
    for line in skipped:
        print('  skipped: %s' % line)
    return 1 if any(v == 'failed' for v in outcomes.values()) else 0


if __name__ == '__main__':
    sys.exit(main())
