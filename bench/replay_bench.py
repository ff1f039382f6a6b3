#!/usr/bin/env python3
"""The bridge on PX4's real stream: recorded PX4 SITL hover replayed at it (bench/px4_replay.py), measured
beside real mavros 1.21's cost on the live stream (reference/px4-sitl-measured.md, "Real mavros 1.21 beside
our parts": 2.08-2.33 % of one core with the project's offb_node, 60 s of hover).

The bridge runs with mavros's defaults (node /mavros, fcu_url udp://:14540@127.0.0.1:14580) and offb_node
beside it, as in that measurement: the bridge's topics have the tutorial's subscribers only, plus this
process's setpoint subscription (the latency). Then, in a second window, every telemetry topic the bridge
publishes is subscribed here and its rate and header stamps measured (a subscriber makes the bridge decode
and publish what it otherwise skips, so that window's CPU is reported apart).

    ./run bench --replay [--duration 60] [--rates-duration 15] [--runs 1] [--out out/bench-replay.json]
"""

import argparse
import json
import os
import signal
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
import benchmark  # noqa: E402  (bench/ is not a package)
from offboard_py.tools.streamstats import latencies_ms, percentile  # noqa: E402

MAVROS_CPU_PCT = benchmark.MAVROS_CPU_PCT  # reference/px4-sitl-measured.md, "Real mavros 1.21 beside our parts"

CPU_TARGET_PCT = 2.0
LATENCY_P99_MS = 2.0
SETTLE_S = 10.0  # after connection: the parameter and mission pulls are over
CLK_TCK = os.sysconf('SC_CLK_TCK')


def wakeups(pid):
    """Context switches (voluntary + involuntary) of all the process's threads: each is a wake-up or a
    preemption; a sleeping thread woken by a datagram counts one voluntary switch when it sleeps again."""
    total = 0
    for tid in os.listdir('/proc/%d/task' % pid):
        try:
            for line in open('/proc/%d/task/%s/status' % (pid, tid)):
                if line.startswith(('voluntary_ctxt_switches', 'nonvoluntary_ctxt_switches')):
                    total += int(line.split()[1])
        except OSError:
            continue
    return total


def measure_window(pids, seconds):
    """CPU (% of one core) and wake-ups a second of each pid over `seconds` of wall time."""
    cpu0 = {k: benchmark.cpu_seconds(p) for k, p in pids.items()}
    wake0 = {k: wakeups(p) for k, p in pids.items()}
    t0 = time.monotonic()
    time.sleep(seconds)
    span = time.monotonic() - t0
    return ({k: (benchmark.cpu_seconds(p) - cpu0[k]) / span * 100.0 for k, p in pids.items()},
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


def run_once(args, logdir, index):
    """One replay: the bridge and offb_node on the replayed stream; CPU, wake-ups, latency, topic rates."""
    setpoint_log = os.path.join(logdir, 'replay-setpoints-%d.txt' % index)
    stats_file = os.path.join(logdir, 'replay-stats-%d.json' % index)
    replay = start([sys.executable, os.path.join(HERE, 'px4_replay.py'), '--setpoint-log', setpoint_log,
                    '--stats', stats_file] + (['--data', args.data] if args.data else []), logdir, 'replay-%d' % index)
    bridge_env = None
    if args.bridge_src:  # another checkout's offboard_py, ahead of this one's
        bridge_env = {'PYTHONPATH': os.path.abspath(args.bridge_src) + os.pathsep + os.environ.get('PYTHONPATH', '')}
    bridge = start(['rosrun', 'offboard_py', 'mavros_bridge.py', '__name:=mavros',
                    '_fcu_url:=udp://:14540@127.0.0.1:14580'], logdir, 'bridge-%d' % index, env=bridge_env)
    node = start(['rosrun', 'offboard_py', 'offb_node.py'], logdir, 'node-%d' % index)
    state = []
    stamps = []
    state_sub = rospy.Subscriber('/mavros/state', State, lambda m: state.append(m))
    sp_sub = rospy.Subscriber('/mavros/setpoint_position/local', PoseStamped,
                              lambda m: stamps.append(m.header.stamp.to_nsec()), tcp_nodelay=True)
    result = {}
    try:
        deadline = time.monotonic() + 60.0
        while not (state and state[-1].connected):
            if time.monotonic() > deadline:
                raise RuntimeError('the bridge did not connect to the replay within 60 s (logs in %s)' % logdir)
            if bridge.poll() is not None:
                raise RuntimeError('the bridge exited with %s (see %s)' % (bridge.returncode, logdir))
            time.sleep(0.2)
        state_sub.unregister()  # the measured window has offb_node's subscribers and the setpoint one
        time.sleep(SETTLE_S)
        pids = {'bridge': bridge_pid(bridge.pid), 'node': bridge_pid(node.pid), 'replay': replay.pid}
        t0 = time.time_ns()
        cpu, wake = measure_window(pids, args.duration)
        t1 = time.time_ns()
        rates = TopicRates()
        time.sleep(2.0)  # the subscriptions connect
        r0 = time.time_ns()
        cpu_sub, wake_sub = measure_window({'bridge': pids['bridge']}, args.rates_duration)
        r1 = time.time_ns()
        rates.close()
        result = {'timesync_rtt_ms': {'p50': percentile(rates.rtt_ms, 50), 'max': max(rates.rtt_ms or [None])},
                  'cpu_pct': cpu, 'wakeups_per_s': wake, 'topics': rates.table(r0, r1),
                  'bridge_cpu_pct_all_topics_subscribed': cpu_sub['bridge'],
                  'bridge_wakeups_per_s_all_topics_subscribed': wake_sub['bridge'],
                  'last_state': {'connected': state[-1].connected, 'armed': state[-1].armed, 'mode': state[-1].mode}}
    finally:
        sp_sub.unregister()
        state_sub.unregister()
        for proc in (node, bridge):
            stop(proc)
        stop(replay, signal.SIGTERM)
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
    p.add_argument('--data', help='the replay data (default bench/data/px4-hover-replay.json.xz)')
    p.add_argument('--out', default=os.path.join(os.getcwd(), 'out', 'bench-replay.json'), help='JSON output')
    args = p.parse_args(argv)
    logdir = tempfile.mkdtemp(prefix='offboard_replay_')
    core = benchmark.start_master(logdir, p.error)
    rospy.init_node('replay_benchmark', anonymous=True, disable_signals=True)
    runs = []
    try:
        for i in range(args.runs):
            print('replay %d of %d: PX4 SITL hover, one message a datagram, %.0f s window ...'
                  % (i + 1, args.runs, args.duration), flush=True)
            runs.append(run_once(args, logdir, i))
            benchmark.forget_stale_nodes(('/mavros', '/offb_node'))
            print_run(runs[-1])
    finally:
        benchmark.stop_master(core)
    result = {'machine': benchmark.machine(), 'command': ' '.join(sys.argv), 'bridge_src': args.bridge_src, 'date_utc': time.strftime(
        '%Y-%m-%d %H:%M', time.gmtime()), 'runs': runs, 'logs': logdir}
    benchmark.write_json(result, args.out)
    return 0


def print_run(r):
    fmt = benchmark.fmt
    bridge = r['cpu_pct']['bridge']
    lines = ['| replayed PX4 SITL hover (one message a datagram) | value | target |', '|---|---|---|',
             '| bridge CPU (%% of one core) | %s %% | <= %.1f %% |' % (fmt(bridge, 2), CPU_TARGET_PCT),
             '| real mavros 1.21 on the live stream (recorded) | %.2f-%.2f %% | |' % MAVROS_CPU_PCT,
             '| bridge / mavros | %.2f-%.2f | |' % (bridge / MAVROS_CPU_PCT[1], bridge / MAVROS_CPU_PCT[0]),
             '| bridge wake-ups (context switches) per s | %s | |' % fmt(r['wakeups_per_s']['bridge'], 0),
             '| offb_node CPU | %s %% | |' % fmt(r['cpu_pct']['node'], 2),
             '| replay CPU (not measured against anything) | %s %% | |' % fmt(r['cpu_pct']['replay'], 2),
             '| latency ROS publish -> FCU p50 / p99 / max | %s / %s / %s ms | p99 <= %.0f |'
             % (fmt(r['latency_ms']['p50'], 2), fmt(r['latency_ms']['p99'], 2), fmt(r['latency_ms']['max'], 2),
                LATENCY_P99_MS),
             '| setpoints at the FCU | %s Hz | 20 |' % fmt(r['setpoints_at_fcu_hz'], 2),
             '| the bridge\'s answer to PX4\'s TIMESYNC p50 / p99 / max | %s / %s / %s ms | < 10 (RTT limit) |'
             % tuple(fmt(r['replay'].get('timesync answer ms ' + k), 2) for k in ('p50', 'p99', 'max')),
             '| the bridge\'s TIMESYNC round trip (timesync_status) p50 / max | %s / %s ms | < 10 |'
             % (fmt(r.get('timesync_rtt_ms', {}).get('p50'), 2), fmt(r.get('timesync_rtt_ms', {}).get('max'), 2)),
             '| bridge CPU with every topic subscribed | %s %% | |' % fmt(r['bridge_cpu_pct_all_topics_subscribed'], 2),
             '', '| topic (all subscribed) | rate (Hz) | stamp lag p50 / max (ms) |', '|---|---|---|']
    for topic, t in r['topics'].items():
        lines.append('| %s | %s | %s / %s |' % (topic, fmt(t['rate_hz'], 1), fmt(t['stamp_lag_p50_ms'], 1),
                                               fmt(t['stamp_lag_max_ms'], 1)))
    print('\n'.join(lines), flush=True)


if __name__ == '__main__':
    sys.exit(main(rospy.myargv()[1:]))
