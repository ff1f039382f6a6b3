#!/usr/bin/env python3
"""Junk at the bridge's FCU port at increasing rates, one vehicle hovering: does the stack hold?

For each rate (datagrams per wall second) the benchmark's stack (one vehicle: simulated PX4, the
bridge, offb_node; bench/benchmark.py's run()) is started with a flood already aimed at the bridge's
FCU port, flies to 2 m and hovers; the flood goes on until the end. The junk is the soak's
(bench/soak.py's junk_for_bridge, the kinds of bridge_fuzz.test, in a pool of --pool datagrams sent
over and over): random bytes, the vehicle's lies with bad CRCs or cut short, the same from other
systems, another component's HEARTBEAT, bad enums and NaN. Reported per rate: the setpoint stream's
inter-arrival p50/p99/max at the simulated PX4 over --duration s of hover, and whether the bridge's
connection-time pulls (parameters, mission) completed, with the time from connection and the
number of tries. The bar: p99 <= 55 ms and both pulls complete within --pull-timeout s
of the connection. Run it through `./run bench --junk` (or with the workspace sourced).
"""

import argparse
import datetime
import os
import random
import sys
import tempfile
import threading
import time

import rospy
from rosgraph_msgs.msg import Log

import benchmark
import harness
from soak_stack import junk_for_bridge  # junk that never says what would end a hover
from offboard_py.testing import mavlink_fuzz, ports

BAR_P99_MS = 55.0
PULLS = {'params': 'PR: parameters received', 'mission': 'WP: mission received'}
RETRY = {'params': 'PR: parameter pull after connection failed', 'mission': 'WP: mission pull after connection failed'}
INSTANCE = 0  # benchmark.run flies multi_uav.launch from instance 0
POLL_S = 0.2


class BridgeLog:
    """What /uav0/mavros logs, with the time it arrived (monotonic s)."""

    def __init__(self, node='/uav%d/mavros' % INSTANCE):
        self.node = node
        self.lines = []
        self.lock = threading.Lock()
        self.sub = rospy.Subscriber('/rosout', Log, self._on_log, queue_size=1000)

    def _on_log(self, msg):
        if msg.name == self.node:
            with self.lock:
                self.lines.append((time.monotonic(), msg.msg))

    def first(self, prefix):
        with self.lock:
            return next((t for t, line in self.lines if line.startswith(prefix)), None)

    def count(self, prefix):
        with self.lock:
            return sum(1 for _, line in self.lines if line.startswith(prefix))

    def close(self):
        self.sub.unregister()


class JunkFlood:
    """benchmark.run's `beside`: the flood from the launch on, and the pulls watched until done or
    pull_timeout_s after the connection (with the flood still on)."""

    def __init__(self, rate_hz, pool, pull_timeout_s):
        self.rate_hz = rate_hz
        self.pool = pool
        self.pull_timeout_s = pull_timeout_s
        self.flood = None
        self.log = BridgeLog()
        self.t0 = None
        self.connected_s = None
        self.result = {}

    def start(self):
        self.t0 = time.monotonic()
        if self.rate_hz > 0:
            self.flood = mavlink_fuzz.Flood(('127.0.0.1', ports.bridge_port(INSTANCE)), self.pool, self.rate_hz)
            self.flood.start()

    def finish(self, watches):
        self.connected_s = watches[0].phases.get('connected')
        deadline = self.t0 + (self.connected_s or 0.0) + self.pull_timeout_s
        while time.monotonic() < deadline and not all(self.log.first(line) for line in PULLS.values()):
            time.sleep(POLL_S)
        self._pulls()

    def _pulls(self):
        connected_s = self.connected_s
        for name, line in PULLS.items():
            done = self.log.first(line)
            self.result[name] = {
                'complete': done is not None,
                's_after_connection': None if done is None or connected_s is None else done - self.t0 - connected_s,
                'tries': self.log.count(RETRY[name]) + 1}

    def stop(self):
        if 'params' not in self.result:  # the stack did not reach hover: what the pulls did meanwhile
            self._pulls()
        if self.flood is not None:
            sent, errors, took = self.flood.stop()
            self.result['flood'] = {'sent': sent, 'send_errors': errors, 'seconds': took,
                                    'achieved_rate': sent / took if took > 0 else None}
            self.flood = None
        self.log.close()


def parse_rates(text):
    try:
        rates = [int(v) for v in text.split(',') if v.strip()]
    except ValueError:
        raise ValueError('--rates takes whole datagrams/s separated by commas, got %r' % text)
    if not rates or min(rates) < 0 or max(rates) > 200000 or rates != sorted(rates):
        raise ValueError('--rates must be increasing, 0..200000 datagrams/s, got %r' % text)
    return rates


def measure(rate, args, pool, logdir):
    beside = JunkFlood(rate, pool, args.pull_timeout)
    try:
        vehicle = benchmark.run(1, args.duration, logdir, beside=beside, startup_timeout_s=args.startup_timeout)[0]
    except RuntimeError as err:
        return {'rate': rate, 'error': str(err), 'holds': False, **beside.result}
    stream = vehicle['stream']
    pulls_ok = all(beside.result.get(name, {}).get('complete') for name in PULLS)
    holds = bool(stream) and stream['p99_ms'] <= BAR_P99_MS and pulls_ok
    return {'rate': rate, 'stream': stream, 'phases_s': vehicle['phases_s'], 'cpu_pct': vehicle['cpu_pct'],
            'holds': holds, **beside.result}


def row(step):
    fmt = harness.fmt
    flood = step.get('flood', {})
    sent = '%s' % fmt(flood.get('achieved_rate'), 0) if flood else '-'

    def pull(name):
        p = step.get(name)
        if not p:
            return '-'
        if not p['complete']:
            return 'no (%d tries)' % p['tries']
        return 'yes, %s s, %d %s' % (fmt(p['s_after_connection']), p['tries'], 'try' if p['tries'] == 1 else 'tries')
    if 'error' in step:
        return '| %d | %s | failed: %s | | | | | no |' % (step['rate'], sent, step['error'])
    s = step['stream'] or {}
    return '| %d | %s | %s / %s / %s | %s | %s | %s | %s |' % (
        step['rate'], sent, fmt(s.get('p50_ms')), fmt(s.get('p99_ms')), fmt(s.get('max_ms')),
        s.get('gaps_over_100ms', '-'), pull('params'), pull('mission'), 'yes' if step['holds'] else '**no**')


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--rates', default='0,250,500,1000,2000,4000,8000',
                   help='junk datagrams per second to try, increasing (0,250,500,1000,2000,4000,8000; 0: none)')
    p.add_argument('--duration', type=float, default=20.0, help='hover seconds measured at each rate (20)')
    p.add_argument('--pull-timeout', type=float, default=60.0,
                   help='seconds after the connection by which both pulls must have completed (60)')
    p.add_argument('--startup-timeout', type=float, default=120.0, help='seconds to reach hover at each rate (120)')
    p.add_argument('--pool', type=int, default=5000, help='distinct junk datagrams, sent over and over (5000)')
    p.add_argument('--seed', type=int, default=2026)
    p.add_argument('--keep-going', action='store_true',
                   help='try every rate (default: stop after the second rate in a row that misses the bar)')
    p.add_argument('--out', default=os.path.join(os.getcwd(), 'out', 'junk_flood.json'), help='JSON output')
    args = p.parse_args(rospy.myargv()[1:])
    try:
        rates = parse_rates(args.rates)
    except ValueError as err:
        p.error(str(err))
    if args.duration <= 1 or args.pull_timeout <= 0 or args.startup_timeout <= 0 or not 1 <= args.pool <= 100000:
        p.error('--duration must be above 1 s, --pull-timeout and --startup-timeout above 0, --pool 1..100000')
    pool = list(junk_for_bridge(random.Random(args.seed), args.pool, ports.system_id(INSTANCE)))
    logdir = tempfile.mkdtemp(prefix='offboard_junk_')
    core = harness.start_master(logdir, p.error)
    rospy.init_node('junk_flood', anonymous=True, disable_signals=True)
    header = ['| junk (datagrams/s) | sent (/s) | setpoint inter-arrival p50 / p99 / max (ms) | gaps > 100 ms '
              '| parameter pull | mission pull | holds |', '|---|---|---|---|---|---|---|']
    steps, misses = [], 0
    try:
        print('\n'.join(header), flush=True)
        for rate in rates:
            step = measure(rate, args, pool, logdir)
            steps.append(step)
            print(row(step), flush=True)
            misses = 0 if step['holds'] else misses + 1
            if misses >= 2 and not args.keep_going:
                break
    finally:
        harness.stop_master(core)
    # the largest rate below which every rate tried held the bar
    held = None
    for step in steps:
        if not step['holds']:
            break
        held = step['rate']
    print('\nbar: setpoint inter-arrival p99 <= %.0f ms at the simulated PX4 and both connection-time pulls '
          'complete within %.0f s of the connection' % (BAR_P99_MS, args.pull_timeout))
    print('largest junk rate holding it (every rate up to it held): %s datagrams/s' % held)
    result = {'command': ' '.join(sys.argv), 'date': datetime.date.today().isoformat(),
              'machine': harness.machine(),
              'bar_p99_ms': BAR_P99_MS, 'pull_timeout_s': args.pull_timeout, 'steps': steps,
              'largest_rate_holding': held, 'table': header + [row(s) for s in steps]}
    harness.write_json(result, args.out)
    return 0


if __name__ == '__main__':
    sys.exit(main())
