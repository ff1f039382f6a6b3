#!/usr/bin/env python3
"""The soak: the stack hovers at 2 m for --minutes simulated minutes while a seeded schedule of
faults is done to it, and every fault must be recovered from and no process may grow in memory.

Starts launch/soak.launch (simulated PX4 -> lossy relay -> bridge, offb_node; the bridge and the
simulator respawned) on a ROS master of its own, waits for hover, then does each fault of the
schedule (offboard_py.tools.soak_rules.make_schedule, printed at the start): link cuts both ways shorter and
longer than conn/timeout and bursts of 10-30 % loss (through the relay's control port), the bridge
and the simulator killed with SIGKILL (roslaunch respawns them), junk floods at the bridge's and
the simulator's ports. Each fault is timed until the vehicle is back in OFFBOARD, armed, within
0.2 m of 2 m; every simulated minute a line gives the mode, the altitude and each process's RSS.
At the end: a table of the faults, the RSS growth of each process after its first minute, a JSON
and a PNG (altitude and mode with the faults marked; RSS over time). Exits 1 saying why when a
fault was not recovered, hover was lost with no fault under way, or a process's RSS grew more than
2 MB after its first minute; 2 on bad arguments. Run it through `./run soak` (which sets up and
sources the workspace).
"""

import argparse
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import time

from offboard_py.tools import soak_rules as soak
from offboard_py.tools.demo import launch_failure
from offboard_py.master import MasterTimeout, wait_for_master
from offboard_py.simtime import SimClock, SpeedError, parse_speed
from offboard_py.testing import mavlink_fuzz, ports

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import soak_report  # noqa: E402  (bench/ is not a package)
import soak_stack  # noqa: E402

DEFAULT_SEED = 17
DEFAULT_INSTANCE = 38  # ports.py: 38 and 39 are for runs by hand
CONN_TIMEOUT_S = 4.0  # the bridge's conn/timeout in soak.launch, as link_cut.test
MIN_MINUTES = (soak.FIRST_FAULT_S + soak.TAIL_S) / 60.0
MAX_MINUTES = 24 * 60.0
# Starting processes takes wall time, whatever the speed: these bounds are simulated seconds, but
# never less than the wall seconds beside them.
STARTUP_BOUND_S, STARTUP_MIN_WALL_S = 180.0, 60.0   # from the launch to the first hover
RESPAWN_BOUND_S, RESPAWN_MIN_WALL_S = 60.0, 20.0    # for roslaunch to bring a killed process back
SAMPLE_PERIOD_S = 5.0       # simulated s between RSS samples
MINUTE_S = 60.0
LOOP_PERIOD_S = 0.05        # wall s between looks at the stack
MAX_CLOCK_LAG_S = 0.5       # as the rostests' clock guard: half of COM_OF_LOSS_T
MASTER_TIMEOUT_S = 30.0     # wall s
CONTROL_TIMEOUT_S = 2.0     # wall s for the relay's answer
STOP_TIMEOUT_S = 60.0       # wall s for roslaunch to stop its nodes
ROLE_ORDER = ('node', 'bridge', 'sim')


# --- the run ---------------------------------------------------------------------------------

class Stop(Exception):
    """The soak cannot go on; the message says why. `counted`: the reason is already a fault's
    (or the start-up's) error, which the verdict reports."""

    def __init__(self, message, counted=False):
        super().__init__(message)
        self.counted = counted


class Soak:
    """One soak run: the launch, the ROS view of the vehicle, the schedule being done."""

    def __init__(self, args, schedule, logdir):
        self.args, self.schedule, self.logdir = args, schedule, logdir
        self.clock = SimClock.for_run(args.speed, strict=False)
        self.startup_bound_s = max(STARTUP_BOUND_S, self.clock.sim_s(STARTUP_MIN_WALL_S))
        self.respawn_bound_s = max(RESPAWN_BOUND_S, self.clock.sim_s(RESPAWN_MIN_WALL_S))
        self.monitor = soak.Monitor()
        self.rss_samples = []     # (t, role, pid, rss_mb)
        self.minute_lines = []    # as printed
        self.worst_lag_s, self.worst_lag_at_s, self.lagging_s = 0.0, None, 0.0
        self.launch = None
        self.t0 = None
        self.hover_said = False
        self.pending = list(schedule)  # faults not done yet
        self.watch = None              # the fault under way (until recovered)
        self.killed = None             # (role, pid) of the process the fault under way killed
        self.instance = args.instance
        self.control = ('127.0.0.1', ports.extra_port(args.instance, 3))
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    def now(self):
        return self.clock.now() - self.t0

    # the stack

    def start(self):
        master_port = ports.free_tcp_port()
        env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % master_port,
                   ROS_LOG_DIR=os.path.join(self.logdir, 'ros'))
        os.environ.update(ROS_MASTER_URI=env['ROS_MASTER_URI'], ROS_LOG_DIR=env['ROS_LOG_DIR'])
        self.launch_log = open(self.args.log, 'w')
        self.t0 = self.clock.now()
        self.launch = subprocess.Popen(
            ['roslaunch', '-p', str(master_port), 'offboard_py', 'soak.launch', 'instance:=%d' % self.instance,
             'speed:=%g' % self.args.speed, 'conn_timeout:=%g' % CONN_TIMEOUT_S],
            env=env, stdout=self.launch_log, stderr=subprocess.STDOUT, start_new_session=True)
        import rosgraph
        import rospy

        def master_up_or_launch_gone():
            return rosgraph.is_master_online() or self.launch.poll() is not None
        try:  # roslaunch starts the master: no "is roscore running?" while it does
            wait_for_master('soak', MASTER_TIMEOUT_S, is_online=master_up_or_launch_gone, say=lambda text: None)
        except MasterTimeout as err:
            raise Stop('%s (roslaunch output: %s)' % (err, self.args.log))
        self.check_launch()
        if self.args.speed != 1.0:  # rospy reads /use_sim_time once, at init_node
            deadline = time.monotonic() + MASTER_TIMEOUT_S
            while not rospy.get_param('/use_sim_time', False):
                if time.monotonic() > deadline:
                    raise Stop('/use_sim_time not set by soak.launch within %.0f s (roslaunch output: %s)'
                               % (MASTER_TIMEOUT_S, self.args.log))
                self.check_launch()
                time.sleep(0.1)
        rospy.init_node('soak', anonymous=True, disable_signals=True)
        from geometry_msgs.msg import PoseStamped
        from mavros_msgs.msg import State
        rospy.Subscriber('/mavros/state', State,
                         lambda m: self.monitor.on_state(self.now(), m.connected, m.mode, m.armed))
        rospy.Subscriber('/mavros/local_position/pose', PoseStamped,
                         lambda m: self.monitor.on_pose(self.now(), m.pose.position.z))
        self.rospy = rospy

    def check_launch(self):
        if self.launch.poll() is not None:
            why = launch_failure(self.args.log)
            raise Stop('roslaunch ended (code %s)%s; see %s' % (
                self.launch.returncode, ': ' + ' | '.join(why) if why else '', self.args.log))

    def stop(self):
        if self.launch is not None and self.launch.poll() is None:
            os.killpg(self.launch.pid, signal.SIGINT)
            try:
                self.launch.wait(timeout=STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                print('roslaunch did not stop within %.0f s of SIGINT: killing it' % STOP_TIMEOUT_S, flush=True)
                os.killpg(self.launch.pid, signal.SIGKILL)
                self.launch.wait(timeout=STOP_TIMEOUT_S)
        if self.launch is not None:
            self.launch_log.close()
        if getattr(self, 'rospy', None):
            self.rospy.signal_shutdown('soak over')

    # what is watched every turn of the loop

    def sample(self, t):
        for role, pid in soak_stack.stack_processes(self.launch.pid).items():
            self.rss_samples.append((t, role, pid, soak_stack.rss_mb(pid)))

    def minute_line(self, t):
        latest = {}
        for _, role, pid, rss in self.rss_samples:
            latest[role] = (pid, rss)
        rss = ', '.join('%s %s MB (pid %d)' % (role, '-' if latest[role][1] is None else '%.1f' % latest[role][1],
                                             latest[role][0]) for role in ROLE_ORDER if role in latest)
        line = 'min %3d  t=%6.1f s  %s | RSS %s' % (round(t / MINUTE_S), t, self.describe_now(t, columns=True),
                                                  rss or 'no processes')
        self.minute_lines.append(line)
        print(line, flush=True)

    def clock_lag(self):
        """Simulated seconds by which this process's ROS time (/clock) trails the vehicles' clock;
        None in real time or before the first /clock."""
        ros_s = self.rospy.get_time()
        if self.args.speed == 1.0 or ros_s == 0.0:
            return None
        lag = self.clock.now() - ros_s
        if lag > self.worst_lag_s:
            self.worst_lag_s, self.worst_lag_at_s = lag, self.now()
        return lag

    # faults

    def relay(self, command):
        self.sock.settimeout(CONTROL_TIMEOUT_S)
        self.sock.sendto(command.encode(), self.control)
        try:
            reply = self.sock.recv(200)
        except socket.timeout:
            return 'the relay did not answer %r within %.0f s (port %d)' % (command, CONTROL_TIMEOUT_S,
                                                                            self.control[1])
        return None if reply == b'ok' else 'the relay refused %r: %s' % (command, reply.decode(errors='replace'))

    def apply(self, fault, watch):
        """Do the fault; on failure set watch.error. A junk flood has ended when this returns; a cut
        or a burst ends by itself fault.seconds later; a kill ends when the process is back, so
        for a kill this returns (role, pid killed), else None."""
        k = fault.kind
        if k in (soak.CUT_SHORT, soak.CUT_LONG):
            watch.error = self.relay('cut %g both' % fault.seconds)
        elif k == soak.LOSS_BURST:
            watch.error = self.relay('drop %g %g both' % (fault.drop, fault.seconds))
        elif k in (soak.BRIDGE_KILL, soak.SIM_KILL):
            role = 'bridge' if k == soak.BRIDGE_KILL else 'sim'
            pid = soak_stack.stack_processes(self.launch.pid).get(role)
            if pid is None:
                watch.error = 'no %s process to kill' % role
                return None
            os.kill(pid, signal.SIGKILL)
            return role, pid
        else:
            target = ports.system_id(self.instance)
            rng = random.Random(fault.seed)
            if k == soak.JUNK_BRIDGE:
                port, junk = ports.extra_port(self.instance, 2), soak_stack.junk_for_bridge(rng, fault.datagrams, target)
            else:
                port, junk = ports.fcu_port(self.instance), soak_stack.junk_for_sim(rng, fault.datagrams, target)
            flood = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                mavlink_fuzz.send_paced(flood, ('127.0.0.1', port), junk)
            finally:
                flood.close()
            watch.end(self.now())
        return None

    def run(self, interrupted):
        """The soak, until --minutes have passed and the last fault is recovered. Raises Stop saying
        why it cannot go on (no hover, a fault not recovered, the launch gone, interrupted)."""
        self.start()
        end_s = self.args.minutes * MINUTE_S
        next_sample, next_minute = 0.0, MINUTE_S
        last_t = self.now()
        while True:
            time.sleep(LOOP_PERIOD_S)
            t = self.now()
            if interrupted:
                raise Stop('interrupted at %.1f s' % t)
            self.check_launch()
            if t >= next_sample:
                self.sample(t)
                next_sample += SAMPLE_PERIOD_S
            if t >= next_minute:
                self.minute_line(t)
                next_minute += MINUTE_S
            lag = self.clock_lag()
            if lag is not None and lag > MAX_CLOCK_LAG_S:
                self.lagging_s += t - last_t
            last_t = t
            if not self.hovering_since_start(t):
                continue
            if self.watch is not None:
                self.follow(t)
            elif self.pending:
                self.next_fault(t)
            elif t >= end_s:
                return

    def describe_now(self, t, columns=False):
        """Mode, armed and altitude as the soak sees them now (an altitude older than 1 s says so)."""
        (connected, mode, armed), z, z_s = self.monitor.snapshot()
        if z is None:
            altitude = 'no altitude yet'
        else:
            altitude = 'z %5.2f m%s' % (z, '' if t - z_s <= 1.0 else ' (no pose for %.0f s)' % (t - z_s))
        return ('%-12s %-8s %s' if columns else '%s, %s, %s') % (
            (mode or '-') if connected else 'no FCU', 'armed' if armed else 'disarmed', altitude)

    def hovering_since_start(self, t):
        """True once the first hover after the launch was seen (said once); Stop after the start-up bound."""
        startup = self.monitor.startup
        if startup.recovered_s is None:
            if t > self.startup_bound_s:
                startup.error = 'no hover within %.0f s of the launch (now %s)' % (self.startup_bound_s,
                                                                                     self.describe_now(t))
                raise Stop(startup.error, counted=True)
            return False
        if not self.hover_said:
            print('hover (OFFBOARD, armed, 2 m +- %.1f m) at %.1f s; the schedule begins'
                  % (soak.RECOVERY_TOLERANCE_M, startup.recovered_s), flush=True)
            self.hover_said = True
        return True

    def next_fault(self, t):
        """Start the next fault when it is due and the vehicle has held hover SETTLE_S."""
        fault = self.pending[0]
        if t < fault.at_s:
            return
        if self.monitor.hover_held_s(t) < soak.SETTLE_S:
            if t > fault.at_s + soak.RECOVERY_BOUND_S + soak.SETTLE_S:
                raise Stop('fault %d is due since %.0f s, but the vehicle has not held hover for %.0f s since '
                           '(now %s; lapses: %s)' % (fault.index, fault.at_s, soak.SETTLE_S, self.describe_now(t),
                                                     self.monitor.lapses[-3:]))
            return
        self.pending.pop(0)
        self.watch = self.monitor.begin(fault, t)
        print('%6.1f s  fault %d/%d: %s' % (t, fault.index, len(self.schedule), fault.what), flush=True)
        self.killed = self.apply(fault, self.watch)
        if self.watch.error:
            raise Stop('fault %d: %s' % (fault.index, self.watch.error), counted=True)

    def follow(self, t):
        """The fault under way: mark its end, then wait (bounded) for the recovery."""
        watch = self.watch
        if watch.end_s is None:
            if self.killed is not None:
                role, old_pid = self.killed
                pid = soak_stack.stack_processes(self.launch.pid).get(role)
                if pid is not None and pid != old_pid:
                    watch.end(t)
                    print('    %s back (pid %d) %.1f s after the kill' % (role, pid, t - watch.start_s), flush=True)
                elif t - watch.start_s > self.respawn_bound_s:
                    watch.error = '%s not respawned within %.0f s' % (role, self.respawn_bound_s)
                    raise Stop('fault %d: %s' % (watch.fault.index, watch.error), counted=True)
            elif t >= watch.start_s + watch.fault.seconds:
                watch.end(watch.start_s + watch.fault.seconds)
        elif watch.recovered_s is not None:
            print('    recovered %.1f s after the fault ended (%.1f s after it began): %s'
                  % (watch.recovery_s, watch.outage_s, watch.effect()), flush=True)
            self.watch, self.killed = None, None
        elif watch.overdue(t):
            watch.error = 'not back in hover within %.0f s of its end (now %s)' % (watch.bound_s,
                                                                                   self.describe_now(t))
            raise Stop('fault %d (%s) %s' % (watch.fault.index, watch.fault.what, watch.error), counted=True)


# --- the command -----------------------------------------------------------------------------

def parse_args(argv):
    p = argparse.ArgumentParser(prog='soak', description=__doc__.split('\n\n')[0])
    p.add_argument('minutes_arg', nargs='?', metavar='MINUTES', help='the same as --minutes')
    p.add_argument('--minutes', metavar='MIN',
                   help='simulated minutes of the soak, %g to %g (default 30)' % (MIN_MINUTES, MAX_MINUTES))
    p.add_argument('--speed', default='5', metavar='K',
                   help='simulated time at K x real time (default 5: a 30-minute soak takes about 6 minutes)')
    p.add_argument('--seed', default=str(DEFAULT_SEED), help='seed of the fault schedule (default %d)' % DEFAULT_SEED)
    p.add_argument('--out', default=os.path.join('out', 'soak.json'),
                   help='JSON to write; the PNG goes beside it (default out/soak.json, out/soak.png)')
    p.add_argument('--log', help='where the launched nodes\' output goes (default: beside the JSON, soak-launch.log)')
    p.add_argument('--instance', default=str(DEFAULT_INSTANCE),
                   help='SITL instance N: ports 14580+N and 15000+10N.. (default %d)' % DEFAULT_INSTANCE)
    args = p.parse_args(argv)
    if args.minutes_arg is not None and args.minutes is not None:
        p.error('give the minutes once: MINUTES (%s) or --minutes (%s)' % (args.minutes_arg, args.minutes))
    args.minutes = args.minutes_arg or args.minutes or '30'
    try:
        args.minutes = float(args.minutes)
    except ValueError:
        p.error('--minutes must be a number of simulated minutes, got %r' % args.minutes)
    if not MIN_MINUTES <= args.minutes <= MAX_MINUTES:
        p.error('--minutes must be between %g (the first fault is due at %.0f s, none in the last minute) and %g, '
                'got %g' % (MIN_MINUTES, soak.FIRST_FAULT_S, MAX_MINUTES, args.minutes))
    try:
        args.speed = parse_speed(args.speed, '--speed')
    except SpeedError as err:
        p.error(str(err))
    try:
        args.seed = int(args.seed)
    except ValueError:
        p.error('--seed must be a whole number, got %r' % args.seed)
    try:
        args.instance = int(args.instance)
        ports.fcu_port(args.instance)
    except ValueError:
        p.error('--instance must be a whole number 0..%d, got %r' % (ports.MAX_INSTANCE, args.instance))
    if os.path.isdir(args.out) or not args.out.endswith('.json'):
        p.error('--out must name a .json file, got %r' % args.out)
    args.out = os.path.abspath(args.out)
    args.log = os.path.abspath(args.log or os.path.join(os.path.dirname(args.out), 'soak-launch.log'))
    return args


def busy_ports(instance):
    """The UDP ports of this instance that something holds now."""
    busy = []
    for port in [ports.fcu_port(instance)] + [ports.extra_port(instance, k) for k in range(4)]:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind(('127.0.0.1', port))
        except OSError:
            busy.append(port)
        finally:
            sock.close()
    return busy


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    busy = busy_ports(args.instance)
    if busy:
        print('soak: UDP ports %s of instance %d are in use (another stack?); stop it or give --instance N'
              % (', '.join(map(str, busy)), args.instance), file=sys.stderr)
        return 2
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    schedule = soak.make_schedule(args.seed, args.minutes, CONN_TIMEOUT_S)
    print('soak: %g simulated minutes at %gx (about %.1f wall minutes), seed %d, instance %d; '
          'conn/timeout %g s, recovery bound %.0f s after each fault, RSS growth limit %g MB; launch output: %s'
          % (args.minutes, args.speed, args.minutes / args.speed, args.seed, args.instance, CONN_TIMEOUT_S,
             soak.RECOVERY_BOUND_S, soak.RSS_LIMIT_MB, args.log))
    print('schedule (planned start, simulated s since the launch; a fault waits for %.0f s of steady hover):'
          % soak.SETTLE_S)
    for f in schedule:
        print('  %2d  at %6.1f s  %-11s  %s' % (f.index, f.at_s, f.kind, f.what))
    sys.stdout.flush()
    logdir = tempfile.mkdtemp(prefix='offboard_soak_')
    run = Soak(args, schedule, logdir)
    stopped = None
    interrupted = []
    signal.signal(signal.SIGINT, lambda *_: interrupted.append(True))
    signal.signal(signal.SIGTERM, lambda *_: interrupted.append(True))
    wall0 = time.monotonic()
    try:
        run.run(interrupted)
    except Stop as err:
        print('soak stopped: %s' % err, flush=True)
        stopped = None if err.counted else str(err)
    finally:
        wall_s = time.monotonic() - wall0
        if run.launch is not None and run.launch.poll() is None:
            run.sample(run.now())
        run.stop()
    reasons = soak_report.report(run, stopped, wall_s, CONN_TIMEOUT_S, MAX_CLOCK_LAG_S)
    print('ROS logs of the nodes: %s' % os.path.join(logdir, 'ros'))
    if reasons:
        print('\nSOAK FAILED:\n  ' + '\n  '.join(reasons))
        return 1
    print('\nsoak passed: %d faults, each recovered; no process grew more than %g MB after its first minute'
          % (len(run.monitor.watches), soak.RSS_LIMIT_MB))
    return 0


if __name__ == '__main__':
    sys.exit(main())
