#!/usr/bin/env python3
"""The bridge on PX4's real stream: recorded PX4 SITL hover replayed at it (bench/px4_replay.py), measured
beside real mavros 1.21's cost on the live stream (reference/px4-sitl-measured.md, "Real mavros 1.21 beside
our parts": 2.08-2.33 % of one core with the project's offb_node, 60 s of hover).

The bridge runs with mavros's defaults (node /mavros, fcu_url udp://:14540@127.0.0.1:14580) and offb_node
beside it, as in that measurement: the bridge's topics have the tutorial's subscribers only, plus this
process's setpoint subscription (the latency). Then, in a second window, every telemetry topic the bridge
publishes is subscribed here and its rate and header stamps measured (a subscriber makes the bridge decode
and publish what it otherwise skips, so that window's CPU is reported apart).

With --compare, real mavros takes the same replay in turns with the bridge (bridge, mavros, bridge, ...:
--runs pairs), started as the PX4 user guide starts it (roslaunch mavros px4.launch, fcu_url as above), and
a table sets the two side by side. Real mavros is looked for with `rospack find mavros`, in this
environment or in the one a --mavros-setup file (a workspace's setup.bash) makes.

    ./run bench --replay [--duration 60] [--rates-duration 15] [--runs 1] [--compare [--mavros-setup FILE]]
                         [--out out/bench-replay.json]
"""

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time

import roslib.message
import rospy
from geometry_msgs.msg import PoseStamped
from mavros_msgs.msg import State

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import harness  # noqa: E402  (bench/ is not a package)
from proc_stats import cpu_seconds, wakeups  # noqa: E402
from offboard_py import stack  # noqa: E402
from offboard_py.tools.streamstats import latencies_ms, percentile  # noqa: E402

MAVROS_CPU_PCT = harness.MAVROS_CPU_PCT  # reference/px4-sitl-measured.md, "Real mavros 1.21 beside our parts"

CPU_TARGET_PCT = 2.0
LATENCY_P99_MS = 2.0
SETTLE_S = 10.0  # after connection: the parameter and mission pulls are over
FCU_URL = 'udp://:14540@127.0.0.1:14580'  # mavros's px4.launch with PX4 SITL's onboard ports
SIDES = {'bridge': 'our bridge', 'mavros': 'real mavros'}
NODE_START_S = 30.0  # roslaunch to a running mavros_node


def side_command(side, mavros_setup=None):
    """The ROS side's command line: the bridge as mavros's node (/mavros), or real mavros as px4.launch starts it."""
    if side == 'bridge':
        return ['rosrun', 'offboard_py', 'mavros_bridge.py', '__name:=mavros', '_fcu_url:=' + FCU_URL]
    return stack.in_setup(['roslaunch', 'mavros', 'px4.launch', 'fcu_url:=' + FCU_URL], mavros_setup)


def process_named(pid, name):
    """pid itself, or a process under it (harness.descends_from), whose command name (/proc/PID/comm, 15
    characters at most) is name; None if none."""
    for candidate in [pid] + [int(p) for p in filter(str.isdigit, os.listdir('/proc'))]:
        try:
            if open('/proc/%d/comm' % candidate).read().strip() == name[:15] and (
                    candidate == pid or harness.descends_from(candidate, pid)):
                return candidate
        except OSError:
            continue
    return None


def measured_pid(side, proc, timeout_s=NODE_START_S):
    """The process whose CPU is the ROS side's: the bridge's python (rosrun may exec it or fork it), or the
    mavros_node that roslaunch starts. RuntimeError naming the side when it does not come up in time."""
    if side == 'bridge':
        return bridge_pid(proc.pid)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        pid = process_named(proc.pid, 'mavros_node')
        if pid is not None:
            return pid
        if proc.poll() is not None:
            break
        time.sleep(0.2)
    raise RuntimeError('no mavros_node under roslaunch mavros px4.launch within %.0f s (roslaunch %s)'
                       % (timeout_s, 'exited with %s' % proc.returncode if proc.poll() is not None else 'still running'))


def measure_window(pids, seconds):
    """CPU (% of one core) and wake-ups a second of each pid over `seconds` of wall time."""
    cpu0 = {k: cpu_seconds(p) for k, p in pids.items()}
    wake0 = {k: wakeups(p) for k, p in pids.items()}
    t0 = time.monotonic()
    time.sleep(seconds)
    span = time.monotonic() - t0
    return ({k: (cpu_seconds(p) - cpu0[k]) / span * 100.0 for k, p in pids.items()},
            {k: (wakeups(p) - wake0[k]) / span for k, p in pids.items()})


class TopicRates:
    """Every topic /mavros publishes that carries data from the FCU, subscribed: count and header stamp lag."""

    SKIP = ('/mavros/setpoint', '/mavros/mavlink/to')

    def __init__(self):
        self.subs, self.seen, self.rtt_ms = [], {}, []
        for topic, kind in rospy.get_published_topics('/mavros'):
            if topic.startswith(self.SKIP):
                continue
            cls = roslib.message.get_message_class(kind)
            if cls is None:
                continue
            self.seen[topic] = []
            self.subs.append(rospy.Subscriber(topic, cls, self._on, callback_args=topic, queue_size=100))

    def _on(self, msg, topic):
        if hasattr(msg, 'round_trip_time_ms'):
            self.rtt_ms.append(msg.round_trip_time_ms)
        header = getattr(msg, 'header', None)
        stamp = header.stamp.to_nsec() if header is not None and hasattr(header, 'stamp') else None
        self.seen[topic].append((time.time_ns(), stamp))

    def close(self):
        for sub in self.subs:
            sub.unregister()

    def table(self, t0_ns, t1_ns):
        out = {}
        for topic, rows in sorted(self.seen.items()):
            inside = [r for r in rows if t0_ns <= r[0] <= t1_ns]
            lags = [(a - s) / 1e6 for a, s in inside if s]
            out[topic] = {'rate_hz': len(inside) / ((t1_ns - t0_ns) / 1e9),
                          'stamp_lag_p50_ms': percentile(lags, 50), 'stamp_lag_max_ms': max(lags) if lags else None}
        return out


def start(cmd, logdir, name, env=None):
    log = open(os.path.join(logdir, name + '.log'), 'w')
    return subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                            env=dict(os.environ, **(env or {})))


def stop(proc, sig=signal.SIGINT, timeout=20):
    if proc.poll() is None:
        os.killpg(proc.pid, sig)
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def run_once(args, logdir, index, side='bridge'):
    """One replay: the ROS side (the bridge, or real mavros) and offb_node on the replayed stream; CPU,
    wake-ups, latency, topic rates."""
    setpoint_log = os.path.join(logdir, 'replay-setpoints-%d.txt' % index)
    stats_file = os.path.join(logdir, 'replay-stats-%d.json' % index)
    replay = start([sys.executable, os.path.join(HERE, 'px4_replay.py'), '--setpoint-log', setpoint_log,
                    '--stats', stats_file] + (['--data', args.data] if args.data else []), logdir, 'replay-%d' % index)
    bridge_env = None
    if args.bridge_src and side == 'bridge':  # another checkout's offboard_py, ahead of this one's
        bridge_env = {'PYTHONPATH': os.path.abspath(args.bridge_src) + os.pathsep + os.environ.get('PYTHONPATH', '')}
    bridge = start(side_command(side, args.mavros_setup), logdir, '%s-%d' % (side, index), env=bridge_env)
    node = start(['rosrun', 'offboard_py', 'offb_node.py'], logdir, 'node-%d' % index)
    state = []
    stamps = []
    state_sub = rospy.Subscriber('/mavros/state', State, lambda m: state.append(m))
    sp_sub = rospy.Subscriber('/mavros/setpoint_position/local', PoseStamped,
                              lambda m: stamps.append(m.header.stamp.to_nsec()), tcp_nodelay=True)
    result = {'side': side}
    try:
        deadline = time.monotonic() + 60.0
        while not (state and state[-1].connected):
            if time.monotonic() > deadline:
                raise RuntimeError('%s did not connect to the replay within 60 s (logs in %s)' % (SIDES[side], logdir))
            if bridge.poll() is not None:
                raise RuntimeError('%s exited with %s (see %s)' % (SIDES[side], bridge.returncode, logdir))
            time.sleep(0.2)
        state_sub.unregister()  # the measured window has offb_node's subscribers and the setpoint one
        time.sleep(SETTLE_S)
        pids = {'bridge': measured_pid(side, bridge), 'node': bridge_pid(node.pid), 'replay': replay.pid}
        t0 = time.time_ns()
        cpu, wake = measure_window(pids, args.duration)
        t1 = time.time_ns()
        rates = TopicRates()
        time.sleep(2.0)  # the subscriptions connect
        r0 = time.time_ns()
        cpu_sub, wake_sub = measure_window({'bridge': pids['bridge']}, args.rates_duration)
        r1 = time.time_ns()
        rates.close()
        result.update({'timesync_rtt_ms': {'p50': percentile(rates.rtt_ms, 50), 'max': max(rates.rtt_ms or [None])},
                  'cpu_pct': cpu, 'wakeups_per_s': wake, 'topics': rates.table(r0, r1),
                  'bridge_cpu_pct_all_topics_subscribed': cpu_sub['bridge'],
                  'bridge_wakeups_per_s_all_topics_subscribed': wake_sub['bridge'],
                  'last_state': {'connected': state[-1].connected, 'armed': state[-1].armed, 'mode': state[-1].mode}})
    finally:
        sp_sub.unregister()
        state_sub.unregister()
        for proc in (node, bridge):
            stop(proc)
        stop(replay, signal.SIGTERM)
        if side == 'mavros':
            forget_params('/mavros')  # px4.launch's parameters are not the bridge's defaults
    if not os.path.exists(setpoint_log):
        raise RuntimeError('the replay wrote no setpoint log (see %s/replay-%d.log)' % (logdir, index))
    rows = [tuple(map(int, line.split())) for line in open(setpoint_log)]
    inside = [r for r in rows if t0 <= r[0] <= t1]
    lat = latencies_ms(inside, stamps)
    result['latency_ms'] = {'count': len(lat), 'p50': percentile(lat, 50), 'p99': percentile(lat, 99),
                            'max': max(lat) if lat else None}
    result['setpoints_at_fcu_hz'] = len(inside) / ((t1 - t0) / 1e9)
    result['replay'] = json.load(open(stats_file))
    return result


def forget_params(namespace):
    """Delete what a launch left on the parameter server under namespace (nothing there: nothing to do)."""
    try:
        if rospy.has_param(namespace):
            rospy.delete_param(namespace)
    except (KeyError, OSError):
        pass


def bridge_pid(rosrun_pid):
    """rosrun execs the script (same pid), or forks it: the python child, if any."""
    try:
        children = open('/proc/%d/task/%d/children' % (rosrun_pid, rosrun_pid)).read().split()
    except OSError:
        children = []
    return int(children[0]) if children else rosrun_pid


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--duration', type=float, default=60.0, help='seconds of the CPU window (60)')
    p.add_argument('--rates-duration', type=float, default=15.0, help='seconds of the topic-rate window (15)')
    p.add_argument('--runs', type=int, default=1, help='replays one after the other (1)')
    p.add_argument('--bridge-src', metavar='DIR',
                   help="run the bridge from another checkout's src/ (the one holding offboard_py/), for A/B runs")
    p.add_argument('--compare', action='store_true',
                   help='real mavros on the same replay, in turns with the bridge (--runs pairs), side by side')
    p.add_argument('--mavros-setup', metavar='FILE',
                   help="a setup.bash that puts real mavros on the package path (default: this environment's)")
    p.add_argument('--data', help='the replay data (default bench/data/px4-hover-replay.json.xz)')
    p.add_argument('--out', default=os.path.join(os.getcwd(), 'out', 'bench-replay.json'), help='JSON output')
    args = p.parse_args(argv)
    if args.runs < 1 or args.duration <= 1 or args.rates_duration <= 1:
        p.error('--runs must be 1 or more and the durations above 1 s')
    if args.mavros_setup and not args.compare:
        p.error('--mavros-setup goes with --compare')
    if args.mavros_setup and not os.path.isfile(args.mavros_setup):
        p.error('--mavros-setup %s: no such file' % args.mavros_setup)
    sides = ('bridge',)
    if args.compare:
        where = stack.rospack_find('mavros', args.mavros_setup)
        if where is None:
            p.error('--compare needs real mavros, and `rospack find mavros` finds no package %s (install it, or '
                    'name its workspace\'s setup.bash with --mavros-setup; without --compare the bridge is set '
                    'beside the figures recorded for it on PX4 SITL, %.2f-%.2f %%)'
                    % (('in the environment of ' + args.mavros_setup if args.mavros_setup else 'here',)
                       + MAVROS_CPU_PCT))
        print('real mavros: %s' % where, flush=True)
        sides = ('bridge', 'mavros')
    logdir = tempfile.mkdtemp(prefix='offboard_replay_')
    core = harness.start_master(logdir, p.error)
    rospy.init_node('replay_benchmark', anonymous=True, disable_signals=True)
    runs = []
    try:
        for i in range(args.runs):
            for side in sides:
                print('replay %d of %d: %s, PX4 SITL hover, one message a datagram, %.0f s window ...'
                      % (i + 1, args.runs, SIDES[side], args.duration), flush=True)
                runs.append(run_once(args, logdir, len(runs), side))
                harness.forget_stale_nodes(('/mavros', '/offb_node'))
                print_run(runs[-1])
        if args.compare:
            print(compare_table(runs), flush=True)
    finally:
        harness.stop_master(core)
    result = {'machine': harness.machine(), 'command': ' '.join(sys.argv), 'bridge_src': args.bridge_src, 'date_utc': time.strftime(
        '%Y-%m-%d %H:%M', time.gmtime()), 'runs': runs, 'logs': logdir}
    harness.write_json(result, args.out)
    return 0


def print_run(r):
    fmt = harness.fmt
    side = r.get('side', 'bridge')
    cpu = r['cpu_pct']['bridge']  # the ROS side's process, whichever it is
    lines = ['| replayed PX4 SITL hover (one message a datagram), %s | value | target |' % SIDES[side], '|---|---|---|',
             '| %s CPU (%% of one core) | %s %% | <= %.1f %% |' % (SIDES[side], fmt(cpu, 2), CPU_TARGET_PCT),
             '| real mavros 1.21 on the live stream (recorded) | %.2f-%.2f %% | |' % MAVROS_CPU_PCT,
             '| %s / recorded mavros | %.2f-%.2f | |' % (SIDES[side], cpu / MAVROS_CPU_PCT[1], cpu / MAVROS_CPU_PCT[0]),
             '| %s wake-ups (context switches) per s | %s | |' % (SIDES[side], fmt(r['wakeups_per_s']['bridge'], 0)),
             '| offb_node CPU | %s %% | |' % fmt(r['cpu_pct']['node'], 2),
             '| replay CPU (not measured against anything) | %s %% | |' % fmt(r['cpu_pct']['replay'], 2),
             '| latency ROS publish -> FCU p50 / p99 / max | %s / %s / %s ms | p99 <= %.0f |'
             % (fmt(r['latency_ms']['p50'], 2), fmt(r['latency_ms']['p99'], 2), fmt(r['latency_ms']['max'], 2),
                LATENCY_P99_MS),
             '| setpoints at the FCU | %s Hz | 20 |' % fmt(r['setpoints_at_fcu_hz'], 2),
             '| the answer to PX4\'s TIMESYNC p50 / p99 / max | %s / %s / %s ms | < 10 (RTT limit) |'
             % tuple(fmt(r['replay'].get('timesync answer ms ' + k), 2) for k in ('p50', 'p99', 'max')),
             '| the TIMESYNC round trip (timesync_status) p50 / max | %s / %s ms | < 10 |'
             % (fmt(r.get('timesync_rtt_ms', {}).get('p50'), 2), fmt(r.get('timesync_rtt_ms', {}).get('max'), 2)),
             '| %s CPU with every topic subscribed | %s %% | |' % (SIDES[side], fmt(r['bridge_cpu_pct_all_topics_subscribed'], 2)),
             '', '| topic (all subscribed) | rate (Hz) | stamp lag p50 / max (ms) |', '|---|---|---|']
    for topic, t in r['topics'].items():
        lines.append('| %s | %s | %s / %s |' % (topic, fmt(t['rate_hz'], 1), fmt(t['stamp_lag_p50_ms'], 1),
                                               fmt(t['stamp_lag_max_ms'], 1)))
    print('\n'.join(lines), flush=True)


def compare_table(runs):
    """The bridge and real mavros side by side: each figure as the runs' values in order, the ratio of the
    medians, and the telemetry topics both publish with each one's rate."""
    fmt = harness.fmt
    by_side = {side: [r for r in runs if r.get('side') == side] for side in SIDES}

    def values(side, get):
        out = []
        for r in by_side[side]:
            try:
                v = get(r)
            except (KeyError, TypeError):
                v = None
            out.append(v)
        return out

    def median(vals):
        vals = [v for v in vals if v is not None]
        return statistics.median(vals) if vals else None

    rows = [('CPU, % of one core', lambda r: r['cpu_pct']['bridge'], 2),
            ('wake-ups per s', lambda r: r['wakeups_per_s']['bridge'], 0),
            ('CPU with every topic subscribed, %', lambda r: r['bridge_cpu_pct_all_topics_subscribed'], 2),
            ('offb_node CPU, %', lambda r: r['cpu_pct']['node'], 2),
            ('latency ROS publish -> FCU p99, ms', lambda r: r['latency_ms']['p99'], 2),
            ('setpoints at the FCU, Hz', lambda r: r['setpoints_at_fcu_hz'], 2),
            ("answer to PX4's TIMESYNC p99, ms", lambda r: r['replay']['timesync answer ms p99'], 2)]
    lines = ['| on the same replay (runs in turn) | our bridge | real mavros | bridge / mavros (medians) |',
             '|---|---|---|---|']
    for label, get, digits in rows:
        ours, theirs = values('bridge', get), values('mavros', get)
        a, b = median(ours), median(theirs)
        lines.append('| %s | %s | %s | %s |' % (label, ' / '.join(fmt(v, digits) for v in ours),
                                                ' / '.join(fmt(v, digits) for v in theirs),
                                                fmt(a / b, 2) if a is not None and b else '-'))
    common = sorted(set.intersection(*[set(r['topics']) for r in runs])) if runs else []
    lines += ['', '| topic both publish (all subscribed) | our bridge, Hz | real mavros, Hz |', '|---|---|---|']
    for topic in common:
        lines.append('| %s | %s | %s |' % (topic, ' / '.join(fmt(v, 1) for v in values('bridge', lambda r: r['topics'][topic]['rate_hz'])),
                                          ' / '.join(fmt(v, 1) for v in values('mavros', lambda r: r['topics'][topic]['rate_hz']))))
    return '\n'.join(lines)

if __name__ == '__main__':
    sys.exit(main(rospy.myargv()[1:]))
