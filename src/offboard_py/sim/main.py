"""Command line of the simulated PX4: `sim_px4.py [options] [NAME=VALUE ...]`.

Runs from a shell or as a roslaunch node (roslaunch's `name:=value` arguments are
dropped, as rospy.myargv() does, without importing rospy).
"""

import argparse
import logging
import os
import signal
import sys

from offboard_py.clock_board import BoardError
from offboard_py.dialect import check_pymavlink_version
from offboard_py.signing import SigningKeyError
from offboard_py.simtime import SimClock, speed_option
from offboard_py.sim.autopilot import DEFAULT_HOME, SimulatedPx4
from offboard_py.sim.commander import READY_S
from offboard_py.sim.loop import run_together
from offboard_py.sim.geo import GeoOrigin
from offboard_py.sim.instrumentation import BenchLogs
from offboard_py.sim.param_store import ParamRejected


VEHICLE_SPACING_M = 3.0  # --vehicles: north of each other, as multi_uav.launch spawns them
INSTANCE_FIELD = '{instance}'  # in --log-dir: the vehicle's instance number


def default_log_dir(environ=os.environ):
    """Where PX4 SITL would have its log/ if its working folder were $ROS_HOME/sim_px4/<instance> (ROS_HOME
    unset: ~/.ros), as px4_sih.py runs real PX4 in $ROS_HOME/px4_sih/<instance>."""
    ros_home = environ.get('ROS_HOME') or os.path.join(os.path.expanduser('~'), '.ros')
    return os.path.join(ros_home, 'sim_px4', INSTANCE_FIELD, 'log')


def _home(text):
    try:
        lat, lon, alt = (float(v) for v in text.split(','))
    except ValueError:
        raise argparse.ArgumentTypeError('expected LAT,LON,ALT in degrees and metres, got %r' % text)
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0 and -500.0 <= alt <= 9000.0):
        raise argparse.ArgumentTypeError('home %r out of range (lat -90..90, lon -180..180, alt -500..9000)' % text)
    return lat, lon, alt


def _spawn(text):
    try:
        x, y = (float(v) for v in text.split(','))
    except ValueError:
        raise argparse.ArgumentTypeError('expected X,Y in metres, got %r' % text)
    if not (abs(x) <= 10000.0 and abs(y) <= 10000.0):
        raise argparse.ArgumentTypeError('spawn %r: more than 10 km from home' % text)
    return x, y


def _instance(text):
    value = int(text)
    if not 0 <= value <= 99:
        raise argparse.ArgumentTypeError('instance must be 0..99, got %d' % value)
    return value


def _vehicles(text):
    value = int(text)
    if not 1 <= value <= 100:
        raise argparse.ArgumentTypeError('--vehicles must be 1..100, got %d' % value)
    return value


def _system_ids(text):
    try:
        ids = [int(v) for v in text.split(',') if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError('expected system ids like 1,255, got %r' % text)
    if not ids or not all(1 <= i <= 255 for i in ids):
        raise argparse.ArgumentTypeError('system ids are 1..255, got %r' % text)
    return ids


def parser():
    p = argparse.ArgumentParser(prog='sim_px4.py', description=(
        'A simulated PX4 multicopter on MAVLink 2 over UDP, as PX4 SITL: system id N+1, '
        'onboard link on local port 14580+N sending to 14540+N (14620 for N=10), ground-station link on 18570+N '
        'sending to 14550; each answers whoever talks to it.'))
    p.add_argument('params', nargs='*', metavar='NAME=VALUE', help='parameter overrides, e.g. COM_OF_LOSS_T=1.0')
    p.add_argument('-i', '--instance', type=_instance, default=0, help='SITL instance N (default 0)')
    p.add_argument('--home', type=_home, default=DEFAULT_HOME,
                   help='home LAT,LON,ALT (deg, deg, m AMSL; default PX4 SITL: %s)' % ','.join(map(str, DEFAULT_HOME)))
    p.add_argument('--spawn', type=_spawn, default=(0.0, 0.0), metavar='X,Y',
                   help='start position in the world, ENU metres from the home above (as x/y in PX4 launch files); '
                        'the vehicle\'s own local frame and home start there')
    p.add_argument('--vehicles', type=_vehicles, default=1, metavar='N',
                   help='run N vehicles in this one process and loop, instances N..N+K-1 (-i the first) with '
                        'their own ports and system ids, spawned %g m apart northwards as in PX4\'s multi-vehicle '
                        'launch files: one wake-up serves them all (default 1)' % VEHICLE_SPACING_M)
    p.add_argument('--bind', default='127.0.0.1', help='address to bind (default 127.0.0.1: loopback only)')
    p.add_argument('--local-port', type=int, help='UDP port to bind (default 14580+N)')
    p.add_argument('--remote-port', type=int, help='UDP port to send to until a client talks (default 14540+N; 14620 for N=10, '
                   'whose 14540+N is the ground station\'s 14550)')
    p.add_argument('--gcs-port', type=int, help='UDP port of the ground-station link (default 18570+N, as PX4 SITL)')
    p.add_argument('--gcs-remote-port', type=int,
                   help='UDP port the ground-station link sends to until a client talks to it (default 14550)')
    p.add_argument('--no-gcs', action='store_true', help='no ground-station link (only the onboard link)')
    p.add_argument('--ready-delay', type=float, default=READY_S,
                   help='seconds after boot before the estimator is ready and arming is allowed '
                        '(default %g, as PX4 SITL; SYS_STATUS says so at the health report\'s next 2 s interval)'
                        % READY_S)
    p.add_argument('--rc', action='store_true', help='simulate an RC link (sticks centred)')
    p.add_argument('--ideal', action='store_true',
                   help='an ideal vehicle: no estimator noise, no hover wander, local z 0 on the ground '
                        '(default: PX4 SITL\'s, seeded by the system id so runs repeat)')
    p.add_argument('--speed', type=speed_option, default=1.0, metavar='K',
                   help='simulated time at K x real time (K > 0, default 1): the model, timers, streams and '
                        'time_boot_ms all run K times faster; the ROS side follows /clock (sim_clock)')
    p.add_argument('--rate', type=float, default=100.0, help='model and controller rate in Hz (default 100)')
    p.add_argument('--steps-per-wakeup', type=int, default=2, metavar='N',
                   help='the loop wakes every N steps and sends their streams together, each message in a '
                        'datagram of its own as PX4 does (default 2; 1: a wake-up a step)')
    p.add_argument('--pack-datagrams', action='store_true',
                   help='NOT PX4\'s framing, for measurements only: pack the messages of a wake-up into as few '
                        'datagrams as fit 1400 bytes (real mavros reads at most 296 bytes of a datagram and '
                        'cannot fly this)')
    p.add_argument('--setpoint-log', metavar='DIR',
                   help='at exit, write DIR/setpoints-N.txt: arrival time (ns, the kernel\'s receive time), '
                        'time_boot_ms and read time (ns, when the simulator handled it) of each accepted '
                        'setpoint, and DIR/stalls-N.txt: when the simulator fell behind its clock and '
                        'skipped steps (for the benchmark)')
    p.add_argument('--signing-key', metavar='FILE',
                   help='MAVLink 2 signing key file in PX4\'s format (32 bytes, optionally + 8-byte timestamp): '
                        'sign everything sent and drop unsigned or badly signed input, as PX4 with a key does')
    p.add_argument('--allow-sysid', type=_system_ids, default=(), metavar='ID[,ID...]',
                   help='take commands, setpoints, parameter and mission writes only from these source '
                        'system ids (default: from anyone)')
    p.add_argument('--log-dir', default=default_log_dir(), metavar='DIR',
                   help='PX4\'s log folder: a ULog file for each flight as PX4 SITL writes one (SDLOG_MODE), in '
                        'DIR/YYYY-MM-DD/HH_MM_SS.ulg, listed and downloaded by the MAVLink log protocol; '
                        '%s is the vehicle\'s instance (default %s); \'\' writes no logs'
                        % (INSTANCE_FIELD, default_log_dir().replace('%', '%%')))
    p.add_argument('--log-level', default='info', choices=('debug', 'info', 'warning', 'error'))
    return p


def vehicles_served(argv):
    """The instances a simulator command line serves (its arguments after sim_px4.py, roslaunch's name:=value
    ones among them): -i N --vehicles K serves N .. N+K-1, read by this parser as main() reads them."""
    args, _ = parser().parse_known_args([a for a in argv if ':=' not in a])
    return range(args.instance, args.instance + args.vehicles)


def configure_logging(args):
    """What the simulator says goes to stdout, its warnings and errors to stderr: as roslaunch's output="log"
    keeps a node's stdout in its log file and still shows its stderr, a clean flight prints nothing there."""
    fmt = logging.Formatter('[sim_px4 %s] %%(message)s' % (
        args.instance if args.vehicles == 1 else '%d-%d' % (args.instance, args.instance + args.vehicles - 1)))
    said, warned = logging.StreamHandler(sys.stdout), logging.StreamHandler(sys.stderr)
    said.addFilter(lambda record: record.levelno < logging.WARNING)
    warned.setLevel(logging.WARNING)
    root = logging.getLogger()
    root.setLevel(args.log_level.upper())
    if root.handlers:  # as logging.basicConfig: a process that configured its logging already keeps it
        return
    for handler in (said, warned):
        handler.setFormatter(fmt)
        root.addHandler(handler)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    args = parser().parse_args([a for a in argv if ':=' not in a])
    configure_logging(args)
    check_pymavlink_version()
    if not 10.0 <= args.rate <= 1000.0:
        logging.error('--rate must be 10..1000 Hz, got %g', args.rate)
        return 2
    if not 1 <= args.steps_per_wakeup <= 10:
        logging.error('--steps-per-wakeup must be 1..10, got %d', args.steps_per_wakeup)
        return 2
    if args.vehicles > 1 and args.log_dir and INSTANCE_FIELD not in args.log_dir:
        logging.error('--log-dir %s would hold the logs of all %d vehicles: put %s in it for each vehicle\'s '
                      'instance', args.log_dir, args.vehicles, INSTANCE_FIELD)
        return 2
    if args.vehicles > 1 and any(port is not None for port in (args.local_port, args.remote_port, args.gcs_port)):
        logging.error('--local-port, --remote-port and --gcs-port name one vehicle\'s ports: with --vehicles, '
                      'each vehicle takes its instance\'s (14580+N, 14540+N, 18570+N)')
        return 2
    try:  # the run's governed clock, where it has one (offboard_py.clock_board), this process a participant
        clock = SimClock.for_run(args.speed, name='sim_px4 %d' % args.instance)
    except BoardError as err:
        logging.error('%s', err)
        return 2
    sims = []
    try:
        for k in range(args.vehicles):
            instance = args.instance + k
            if instance > 99:
                raise ValueError('--vehicles %d from instance %d: instances end at 99' % (args.vehicles, args.instance))
            home = GeoOrigin(*args.home).to_global(args.spawn[1] + k * VEHICLE_SPACING_M, args.spawn[0], 0.0)
            sims.append(SimulatedPx4(
                instance=instance, home=home, bind_host=args.bind, local_port=args.local_port,
                remote_port=args.remote_port, param_overrides=args.params, ready_delay_s=args.ready_delay,
                rc=args.rc, rate_hz=args.rate, steps_per_wakeup=args.steps_per_wakeup, clock=clock,
                pack_datagrams=args.pack_datagrams, signing_key_file=args.signing_key,
                allowed_systems=args.allow_sysid, gcs=not args.no_gcs, gcs_port=args.gcs_port,
                gcs_remote_port=args.gcs_remote_port,
                log_dir=os.path.expanduser(args.log_dir).replace(INSTANCE_FIELD, str(instance))))
    except (ParamRejected, SigningKeyError, ValueError) as err:
        logging.error('%s', err)
        return 2
    except OSError as err:
        logging.error('%s', err)
        return 1
    finally:
        if len(sims) < args.vehicles:
            for sim in sims:
                sim.close_links()
    for sim in sims:
        if args.ideal:
            sim.flight.set_ideal()
    bench_logs = BenchLogs(sims, args.setpoint_log, args.instance, clock) if args.setpoint_log else None

    def stop(_signum, _frame):
        for sim in sims:
            sim.stop()
    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    try:
        run_together(sims, on_stall=None if bench_logs is None else bench_logs.on_stall)
    finally:
        clock.leave()
        for sim in sims:
            sim.close()
        if bench_logs is not None:
            bench_logs.write()
    return 0
