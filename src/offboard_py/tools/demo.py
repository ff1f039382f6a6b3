"""The takeoff demo: run start_offb.launch, show a live status line, plot the climb.

Starts `roslaunch offboard_py start_offb.launch` (which starts a master if none runs),
watches /mavros/state, /mavros/local_position/pose and the node's setpoints, and prints
one status line (time, mode, armed, altitude). Once the vehicle has held the setpoint
altitude for `--hold` seconds it writes a PNG of altitude and setpoint over time with
the connection, OFFBOARD and arming events marked, says where, stops the launch and
exits 0. `--keep-flying` goes on until Ctrl-C; `--bag FILE` records the flight.
Exits 1 (saying what it saw) when the vehicle does not get there in `--timeout` s.
"""

import argparse
import os
import re
import signal
import subprocess
import sys
import threading
import time

from offboard_py import stack
from offboard_py.master import MasterTimeout, master_online, wait_for_master
from offboard_py.tools.hover_phases import PhaseWatcher
from offboard_py.simtime import SimClock, speed_option

HOLD_TOLERANCE_M = 0.1
MASTER_TIMEOUT_S = 30.0
BAG_TOPICS = ['/mavros/state', '/mavros/extended_state', '/mavros/local_position/pose',
              '/mavros/setpoint_position/local', '/rosout']


EVENT_LABELS = {'connected': 'FCU connected', 'offboard': 'OFFBOARD', 'armed': 'armed'}


class Recorder:
    """What the demo saw, with times relative to its start: the phases, altitude and setpoint."""

    def __init__(self, t0, clock=time.monotonic):
        self.phases = PhaseWatcher(t0, clock=clock)
        self.lock = threading.Lock()
        self.altitude = []   # (t, z ENU)
        self.setpoint = []   # (t, z ENU)

    def now(self):
        return self.phases.now()

    def on_pose(self, msg):
        self.phases.on_pose(msg)
        with self.lock:
            self.altitude.append((self.now(), msg.pose.position.z))

    def on_setpoint(self, msg):
        with self.lock:
            self.setpoint.append((self.now(), msg.pose.position.z))

    def events(self):
        """(t, label) of each connection, OFFBOARD and arming, for the plot."""
        with self.phases.lock:
            return [(t, EVENT_LABELS[phase]) for t, phase in self.phases.events]

    def z(self):
        return self.altitude[-1][1] if self.altitude else float('nan')

    def target(self):
        return self.setpoint[-1][1] if self.setpoint else None

    def held_for(self, tolerance_m):
        """Seconds the altitude has stayed within tolerance of the latest setpoint (while armed OFFBOARD)."""
        target = self.target()
        if target is None or not (self.phases.armed and self.phases.mode == 'OFFBOARD'):
            return 0.0
        with self.lock:
            end = self.now()
            start = end
            for t, z in reversed(self.altitude):
                if abs(z - target) > tolerance_m:
                    break
                start = t
        return end - start

    def status(self):
        return 't=%5.1fs  %-12s %-8s  alt %5.2f m' % (self.now(), self.phases.mode or 'no FCU',
                                                       'ARMED' if self.phases.armed else 'disarmed', self.z())


def stack_label(launch_args):
    """Which stack the launch arguments fly, in words (start_offb.launch's fcu, bridge, px4_sitl)."""
    given = dict(a.split(':=', 1) for a in launch_args)
    if given.get('px4_sitl', 'false').lower() in ('true', '1'):
        return 'real mavros + real PX4 SITL (Gazebo Classic)'
    return stack.describe(given.get('fcu', 'sim'), given.get('bridge', 'ours'))


def plot_title(label):
    """The plot's title: which stack flew."""
    return 'offboard_py takeoff demo: offb_node -> %s' % label.replace(' + ', ' -> ')


def plot(recorder, path, label='our mavros-compatible bridge + our simulated PX4'):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    with recorder.lock:
        alt, sp = list(recorder.altitude), list(recorder.setpoint)
    events = recorder.events()
    fig, ax = plt.subplots(figsize=(9, 4.5), dpi=110)
    if sp:
        ax.step([t for t, _ in sp], [z for _, z in sp], where='post', linestyle='--', color='tab:orange',
                label='setpoint z (ENU)')
    ax.plot([t for t, _ in alt], [z for _, z in alt], color='tab:blue', label='altitude z (ENU)')
    top = max([z for _, z in alt + sp] + [1.0])
    for t, event in events:
        ax.axvline(t, color='grey', linestyle=':')
        ax.text(t, top * 0.05, event + ' ', rotation=90, va='bottom', ha='right', fontsize=8)
    ax.set_xlabel('time since start (s)')
    ax.set_ylabel('altitude (m)')
    ax.set_ylim(min(-0.1, min([z for _, z in alt] + [0.0])), top * 1.2)
    ax.set_title(plot_title(label), fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc='lower right')
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def parse_args(argv):
    p = argparse.ArgumentParser(prog='takeoff_demo.py', description=__doc__.split('\n\n')[0])
    p.add_argument('--plot', default=os.path.join(os.getcwd(), 'out', 'takeoff.png'), help='PNG to write')
    p.add_argument('--hold', type=float, default=3.0, help='seconds at the setpoint before the plot (default 3)')
    p.add_argument('--timeout', type=float, default=120.0, help='give up after this many seconds (default 120)')
    p.add_argument('--speed', type=speed_option, default=1.0, metavar='K',
                   help='simulated time at K x real time (default 1: real time); --hold and --timeout and the '
                        'times shown are then simulated seconds')
    p.add_argument('--keep-flying', action='store_true', help='keep flying after the plot, until Ctrl-C')
    p.add_argument('--bag', metavar='FILE', help='record the flight to this rosbag')
    p.add_argument('--log', default=os.path.join(os.getcwd(), 'out', 'demo-launch.log'),
                   help='where the launched nodes\' output goes')
    p.add_argument('launch_args', nargs='*', metavar='name:=value', help='passed to start_offb.launch')
    args = p.parse_args(argv)
    for name in ('hold', 'timeout'):
        if not 0.0 < getattr(args, name) < 1e6:
            p.error('--%s must be a positive number of seconds' % name)
    bad = [a for a in args.launch_args if ':=' not in a]
    if bad:
        p.error('launch arguments must look like name:=value, got %s' % ' '.join(bad))
    if any(a.startswith('speed:=') for a in args.launch_args):
        p.error('give the speed as --speed K (the demo times the flight on that clock), not speed:=')
    if args.speed != 1.0:
        args.launch_args.append('speed:=%g' % args.speed)
    return args


def _stop(proc, timeout_s=15.0):
    if proc is None or proc.poll() is not None:
        return
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def said_launch_ended(launch, log_path, what):
    """Say that roslaunch ended (`what` % its exit code), where its log is and what it said last; 1."""
    print((what + '; see %s') % (launch.returncode, log_path))
    for line in launch_failure(log_path):
        print('  ' + line)
    return 1


def launch_failure(path, lines=6):
    """Why roslaunch ended, from its log, at most `lines` lines: first what a node said was FATAL and the
    required processes that died (the cause, in order), then the last of the other lines that say a process
    failed or died and the simulator's last words (a fleet's simulators log their counters at exit, after
    the cause)."""
    try:
        with open(path, errors='replace') as f:
            text = f.read().splitlines()
    except OSError:
        return []
    keys = ('error', 'fatal', 'died', 'not found')
    plain = (re.sub(r'\x1b\[[0-9;]*m|\x1b\][^\x07]*\x07|={3,}', '', line).strip() for line in text)  # no colours, titles, rules
    said = [line for line in plain if line.startswith('[sim_px4') or any(k in line.lower() for k in keys)]
    causes = [line for line in said if line.startswith('[FATAL]') or line.startswith('REQUIRED process')][:lines]
    rest = [line for line in said if line not in causes]
    room = lines - len(causes)
    return causes + (rest[-room:] if room else [])


class _HalfJoined(Exception):
    """The demo ends while rospy.init_node is still registering with a master that is gone: rospy holds its
    topic lock meanwhile, so rospy.signal_shutdown (and rospy's exit handler) would wait for it for good."""

    def __init__(self, code):
        super().__init__(code)
        self.code = code


def main(argv=None):
    """The demo; the process exit code."""
    try:
        return _run(argv)
    except _HalfJoined as end:  # the launch is stopped already: end the process without rospy's shutdown
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(end.code)


def _run(argv):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    os.makedirs(os.path.dirname(os.path.abspath(args.log)), exist_ok=True)
    tty = sys.stdout.isatty()
    clock = SimClock.for_run(args.speed, strict=False)
    t0 = clock.now()
    log = open(args.log, 'w')
    launch = subprocess.Popen(['roslaunch', 'offboard_py', 'start_offb.launch'] + args.launch_args,
                              stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    bag = None
    interrupted = []
    signal.signal(signal.SIGINT, lambda *_: interrupted.append(True))
    try:
        import rospy
        from geometry_msgs.msg import PoseStamped
        from mavros_msgs.msg import State

        def master_up_or_no_point_waiting():
            return master_online() or launch.poll() is not None or bool(interrupted)
        try:  # roslaunch starts the master: no "is roscore running?" while it does
            wait_for_master('takeoff_demo', MASTER_TIMEOUT_S, is_online=master_up_or_no_point_waiting,
                            say=lambda text: None)
        except MasterTimeout as err:
            print('%s; roslaunch output: %s' % (err, args.log))
            return 1
        if launch.poll() is not None:
            return said_launch_ended(launch, args.log, 'roslaunch exited (code %s) before the ROS master came up')
        if interrupted:
            print('interrupted while waiting for the ROS master')
            return 1
        # The launch may still fail once its master is up (a missing PX4 build, an unknown fcu), taking the
        # master with it: rospy.init_node would then wait for it for good. Join from a thread, watching roslaunch.
        joined = threading.Event()
        threading.Thread(target=lambda: (rospy.init_node('takeoff_demo', disable_signals=True), joined.set()),
                         daemon=True).start()
        join_deadline = time.monotonic() + MASTER_TIMEOUT_S
        while not joined.wait(0.2):
            if launch.poll() is not None or interrupted or time.monotonic() > join_deadline:
                if launch.poll() is not None:
                    code = said_launch_ended(launch, args.log,
                                             'roslaunch exited (code %s) before the demo joined its ROS master')
                else:
                    print('interrupted while joining the ROS master' if interrupted else
                          'could not join the ROS master within %.0f s; roslaunch output: %s'
                          % (MASTER_TIMEOUT_S, args.log))
                    code = 1
                raise _HalfJoined(code)
        rec = Recorder(t0, clock)
        rospy.Subscriber('/mavros/state', State, rec.phases.on_state)
        rospy.Subscriber('/mavros/local_position/pose', PoseStamped, rec.on_pose)
        rospy.Subscriber('/mavros/setpoint_position/local', PoseStamped, rec.on_setpoint)
        if args.bag:
            bag = subprocess.Popen(['rosbag', 'record', '-q', '-O', args.bag] + BAG_TOPICS,
                                   stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        label = stack_label(args.launch_args)
        print('takeoff demo: offb_node -> %s%s (node output: %s)'
              % (label.replace(' + ', ' -> '), '' if clock.real_time else ', simulated time at %gx' % args.speed,
                 args.log))
        plotted = False
        last_line = 0.0
        while not interrupted:
            if launch.poll() is not None:
                return said_launch_ended(launch, args.log, '\nroslaunch ended (code %s), the vehicle is gone')
            if tty:
                sys.stdout.write('\r' + rec.status() + '   ')
                sys.stdout.flush()
            elif rec.now() - last_line >= 2.0:
                print(rec.status(), flush=True)
                last_line = rec.now()
            if not plotted and rec.held_for(HOLD_TOLERANCE_M) >= args.hold:
                plot(rec, args.plot, label)
                plotted = True
                print('\n' if tty else '', end='')
                print('held %.1f m for %.0f s at t=%.1f s; plot: %s' % (rec.target(), args.hold, rec.now(),
                                                                         os.path.abspath(args.plot)), flush=True)
                if not args.keep_flying:
                    return 0
            if not plotted and rec.now() > args.timeout:
                print('\nno hover within %.0f s: %s; see %s' % (args.timeout, rec.status(), args.log))
                return 1
            time.sleep(0.1)
        print()
        return 0
    finally:
        _stop(bag)
        _stop(launch)
        log.close()
