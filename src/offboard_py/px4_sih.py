"""Run a real PX4 SITL with PX4's SIH quadrotor (no Gazebo) from a PX4-Autopilot tree the user built.

`fcu:=px4_sih` in the launch files runs this instead of the simulated PX4: it finds
`<px4_dir>/build/px4_sitl_default/bin/px4` (built with `make px4_sitl_default`), makes a fresh
working folder for the instance (fresh parameters at every start, as the reference recordings
were made), and replaces itself with PX4 started as PX4's own multi-instance script starts it:
`px4 -i N -d <build>/etc` in that folder, airframe 10040 (sihsim_quadx). PX4 SITL instance N
then speaks MAVLink on the same ports as our simulator's instance N (onboard link 14580+N ->
14540+N, GCS link 18570+N -> 14550), with system id N+1; above instance 9 PX4 sends its onboard link
to 14549 until something speaks to it, and the bridge's HEARTBEAT does.

What is missing (no folder, no build, a build without the SIH airframe) is one error naming it,
and the exit code 1 ends the launch (the node is required). Nothing here builds PX4.
"""

import argparse
import os
import shutil
import sys

SIH_QUAD_AUTOSTART = '10040'  # ROMFS/px4fmu_common/init.d-posix/airframes/10040_sihsim_quadx
BUILD = os.path.join('build', 'px4_sitl_default')


class MissingPx4(Exception):
    """A PX4 SITL build that cannot be run; the message says what is missing and how to get it."""


def find_build(px4_dir):
    """(px4 binary, etc folder) of the build in px4_dir. Raises MissingPx4."""
    if not px4_dir:
        raise MissingPx4('fcu:=px4_sih needs a PX4-Autopilot tree built with `make px4_sitl_default`: '
                         'give it as px4_dir:=DIR or in $PX4_DIR (neither is set)')
    px4_dir = os.path.abspath(os.path.expanduser(px4_dir))
    if not os.path.isdir(px4_dir):
        raise MissingPx4('px4_dir %s: no such folder (a PX4-Autopilot tree built with `make px4_sitl_default`)'
                         % px4_dir)
    binary = os.path.join(px4_dir, BUILD, 'bin', 'px4')
    etc = os.path.join(px4_dir, BUILD, 'etc')
    if not os.access(binary, os.X_OK):
        raise MissingPx4('px4_dir %s has no PX4 SITL build: %s not found (run `make px4_sitl_default` there)'
                         % (px4_dir, binary))
    airframes = os.path.join(etc, 'init.d-posix', 'airframes')
    if os.path.isdir(airframes) and not any(name.startswith(SIH_QUAD_AUTOSTART + '_') for name in os.listdir(airframes)):
        raise MissingPx4('the PX4 build in %s has no SIH quadrotor airframe (%s_sihsim_quadx in %s)'
                         % (px4_dir, SIH_QUAD_AUTOSTART, airframes))
    return binary, etc


def environment(speed, base=None):
    """PX4's start-up variables for a headless SIH quadrotor at `speed` x real time."""
    env = dict(os.environ if base is None else base)
    env.update(PX4_SYS_AUTOSTART=SIH_QUAD_AUTOSTART, PX4_SIM_MODEL='sihsim_quadx', PX4_SIMULATOR='sihsim',
               HEADLESS='1')
    if speed != 1.0:
        env['PX4_SIM_SPEED_FACTOR'] = '%g' % speed
    return env


def fresh_work_dir(root, instance):
    """An empty working folder for the instance: PX4 keeps its parameters there."""
    path = os.path.join(root, 'px4_sih', str(instance))
    shutil.rmtree(path, ignore_errors=True)
    os.makedirs(path)
    return path


def parser():
    p = argparse.ArgumentParser(prog='px4_sih.py', description=__doc__.split('\n\n')[0])
    p.add_argument('-i', '--instance', type=int, default=0, help='PX4 SITL instance N (system id N+1)')
    p.add_argument('--px4-dir', default=os.environ.get('PX4_DIR', ''),
                   help='the PX4-Autopilot tree (default $PX4_DIR), built with `make px4_sitl_default`')
    p.add_argument('--speed', type=float, default=1.0, help='PX4_SIM_SPEED_FACTOR (default 1: real time)')
    p.add_argument('--work-dir', default=os.path.join(os.environ.get('ROS_HOME', os.path.expanduser('~/.ros'))),
                   help='where the instance\'s fresh working folder is made (default $ROS_HOME or ~/.ros)')
    return p


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    args = parser().parse_args([a for a in argv if ':=' not in a])  # roslaunch adds __name:= and __log:=
    if not 0 <= args.instance <= 200:
        print('px4_sih: instance must be 0..200, got %d' % args.instance, file=sys.stderr)
        return 2
    if not 0.0 < args.speed <= 100.0:
        print('px4_sih: --speed must be in (0, 100], got %g' % args.speed, file=sys.stderr)
        return 2
    try:
        binary, etc = find_build(args.px4_dir)
    except MissingPx4 as err:
        print('px4_sih: error: %s' % err, file=sys.stderr)
        return 1
    work = fresh_work_dir(args.work_dir, args.instance)
    print('px4_sih: PX4 SITL (SIH quadrotor) instance %d from %s in %s' % (args.instance, binary, work), flush=True)
    os.chdir(work)
    os.execve(binary, [binary, '-i', str(args.instance), '-d', etc], environment(args.speed))
