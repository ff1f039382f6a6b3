"""A fleet across machines (README: "A fleet across machines"), with network namespaces as hosts.

Three hosts a, b, c, each a network namespace with one veth to a switch (a Linux bridge in a
fourth namespace, holding no address), as three machines on one LAN. The addresses (10.231.0.0/24)
exist only inside those namespaces: the root namespace's links, addresses and routes are not
touched, and each host's loopback and ports are its own, so this test shares no port with tests
running beside it. Each host does what the README says a host does:

  a  roscore; vehicle 0   (ROS_IP 10.231.0.1, ROS_MASTER_URI http://10.231.0.1:11311)
  b  vehicle 1            (ROS_IP 10.231.0.2, the same master)
  c  vehicle 2            (ROS_IP 10.231.0.3, the same master)

a vehicle being `roslaunch offboard_py multi_uav.launch n:=1 first:=<id>`: its simulator, its
bridge and its offb_node in uav<id>, in real time. An observer node on host a watches every
vehicle's mavros/state, local_position/pose and setpoint_position/local: all three must fly
OFFBOARD, armed, at 2 m +- 0.3 m, and the remote vehicles' setpoint streams must reach host a at
about 20 Hz. It prints the time to all hovering and the rates.

Needs root and `ip netns` (skipped, saying so, without them). Everything it starts is stopped by
process group and its namespaces are deleted afterwards, also on failure, Ctrl-C or SIGTERM;
namespaces left by a run that was killed outright (opf-<pid>-* of a pid no longer running) are
deleted by the next run.

Run as a script (`test_fleet_netns.py observe ID ...`) this file is the observer.
"""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

import pytest

from offboard_py.clock_board import pid_alive
from offboard_py.testing.processes import OutputProcess

SUBNET_PREFIX = '10.231.0.'
PREFIX_LEN = 24
HOSTS = ('a', 'b', 'c')                          # host a holds the master
VEHICLE_OF_HOST = {'a': 0, 'b': 1, 'c': 2}       # first:= on each host, one vehicle each
MASTER_PORT = 11311
TARGET_Z_M = 2.0                                 # offb_node's setpoint
HOVER_TOLERANCE_M = 0.3
SETPOINT_RATE_HZ = 20.0
RATE_TOLERANCE = 0.2                             # generous: a busy 2-core machine, TCPROS across hosts
MASTER_TIMEOUT_S = 45.0                          # roscore up, from its start
HOVER_TIMEOUT_S = 120.0                          # all three hovering, from the launches' start
HOLD_S = 10.0                                    # then they hold the hover while the rates are measured
OBSERVER_PERIOD_S = 0.5
STOP_TIMEOUT_S = 15.0                            # for a process group to stop on SIGINT before it is killed
NETNS_PATTERN = re.compile(r'^opf-(\d+)-(a|b|c|sw|probe)$')
STATUS_PREFIX = 'fleet '
ROS_NODES = ('mavros', 'offb_node_py')           # a vehicle's nodes, in uav<id>


# --- hosts: network namespaces -------------------------------------------------------------

def ip(*args, timeout_s=10.0):
    """Run `ip ARGS`; raise RuntimeError naming the command and what ip said when it fails."""
    done = subprocess.run(['ip'] + list(args), capture_output=True, text=True, timeout=timeout_s)
    if done.returncode != 0:
        raise RuntimeError('ip %s: %s' % (' '.join(args), (done.stderr or done.stdout).strip()))
    return done.stdout


def netns_names():
    """The network namespaces `ip netns list` shows."""
    return [line.split()[0] for line in ip('netns', 'list').splitlines() if line.strip()]


def why_no_netns():
    """Why this test cannot build hosts here, or None when it can."""
    if os.geteuid() != 0:
        return 'needs root to create network namespaces (running as uid %d)' % os.geteuid()
    if shutil.which('ip') is None:
        return "needs iproute2's `ip` on PATH"
    probe = 'opf-%d-probe' % os.getpid()
    try:
        ip('netns', 'add', probe)
    except (RuntimeError, OSError, subprocess.SubprocessError) as e:
        return '`ip netns` is not available here: %s' % e
    try:
        ip('-n', probe, 'link', 'add', 'br0', 'type', 'bridge')
    except RuntimeError as e:
        return 'no bridge device in a network namespace: %s' % e
    finally:
        ip('netns', 'delete', probe)
    return None


def delete_netns(name):
    """Kill what still runs in the namespace (by pid), then delete it."""
    for pid in ip('netns', 'pids', name).split():
        try:
            os.kill(int(pid), signal.SIGKILL)
        except ProcessLookupError:
            pass
    ip('netns', 'delete', name)


def delete_stale_netns():
    """Namespaces of an earlier run of this test killed before it could clean up (its pid is gone)."""
    for name in netns_names():
        match = NETNS_PATTERN.match(name)
        if match and not pid_alive(int(match.group(1))):
            delete_netns(name)


class Fleet:
    """Three hosts on one switch; processes started in them are stopped by close()."""

    def __init__(self):
        self.tag = 'opf-%d' % os.getpid()
        self.switch = self.tag + '-sw'
        self.netns = {h: '%s-%s' % (self.tag, h) for h in HOSTS}
        self.address = {h: SUBNET_PREFIX + str(i + 1) for i, h in enumerate(HOSTS)}
        self.master_uri = 'http://%s:%d' % (self.address['a'], MASTER_PORT)
        self.log_dir = tempfile.mkdtemp(prefix=self.tag + '-log-')
        self.created = []
        self.processes = []
        self.master = None

    def build(self):
        self._add_netns(self.switch)
        ip('-n', self.switch, 'link', 'add', 'br0', 'type', 'bridge')
        ip('-n', self.switch, 'link', 'set', 'br0', 'up')
        for h in HOSTS:
            ns = self._add_netns(self.netns[h])
            # created inside the switch's namespace, its peer moved straight into the host's: no end
            # of it is ever in the root namespace
            ip('-n', self.switch, 'link', 'add', 'port-' + h, 'type', 'veth', 'peer', 'name', 'eth0', 'netns', ns)
            ip('-n', self.switch, 'link', 'set', 'port-' + h, 'master', 'br0', 'up')
            ip('-n', ns, 'link', 'set', 'lo', 'up')
            ip('-n', ns, 'address', 'add', '%s/%d' % (self.address[h], PREFIX_LEN), 'dev', 'eth0')
            ip('-n', ns, 'link', 'set', 'eth0', 'up')

    def _add_netns(self, name):
        ip('netns', 'add', name)
        self.created.append(name)
        return name

    def env(self, host):
        """A shell on this host as the README sets it up: the workspace sourced (this process's
        environment), ROS_MASTER_URI at host a, ROS_IP this host's address, no ROS_HOSTNAME (it would
        win over ROS_IP; `./run` sets it to localhost only when neither is set)."""
        env = dict(os.environ, ROS_MASTER_URI=self.master_uri, ROS_IP=self.address[host],
                   ROS_LOG_DIR=self.log_dir, PYTHONUNBUFFERED='1')
        env.pop('ROS_HOSTNAME', None)
        return env

    def run(self, host, args):
        """args in the host's namespace and environment, in a process group of its own."""
        proc = OutputProcess(['ip', 'netns', 'exec', self.netns[host]] + list(args), env=self.env(host),
                             new_session=True)
        self.processes.append(proc)
        return proc

    def start_master(self):
        """roscore on host a, at the port of the fleet's ROS_MASTER_URI."""
        self.master = self.run('a', ['roscore', '-p', str(MASTER_PORT)])
        return self.master

    def close(self):
        """Stop every process group (the master last), delete the namespaces; return what is left
        over, as messages (none when clean)."""
        # all but the master together (a roslaunch takes seconds to stop its nodes), then the master
        stoppers = [threading.Thread(target=proc.stop, args=(signal.SIGINT, STOP_TIMEOUT_S))
                    for proc in self.processes if proc is not self.master]
        for stopper in stoppers:
            stopper.start()
        for stopper in stoppers:
            stopper.join()
        if self.master is not None:
            self.master.stop(signal.SIGINT, STOP_TIMEOUT_S)
        for name in reversed(self.created):
            try:
                delete_netns(name)
            except RuntimeError:
                pass  # reported below if it is still listed
        shutil.rmtree(self.log_dir, ignore_errors=True)
        left = ['namespace %s still listed by `ip netns list`' % name
                for name in netns_names() if name in self.created]
        root_addresses = ip('-o', 'address', 'show')
        if SUBNET_PREFIX in root_addresses:
            left.append('an address %s* in the root namespace:\n%s' % (SUBNET_PREFIX, root_addresses))
        return left


def raise_keyboard_interrupt(signum, frame):
    raise KeyboardInterrupt('signal %d' % signum)


@pytest.fixture
def fleet(capsys):
    reason = why_no_netns()
    if reason is not None:
        with capsys.disabled():
            print('\ntest_fleet_netns skipped: ' + reason, flush=True)
        pytest.skip(reason)
    delete_stale_netns()
    # SIGTERM (a CI job's timeout) ends the test the way Ctrl-C does, so the clean-up below runs
    previous_sigterm = signal.signal(signal.SIGTERM, raise_keyboard_interrupt)
    fleet = Fleet()
    try:
        fleet.build()
        yield fleet
    finally:
        # a second Ctrl-C or SIGTERM must not cut the clean-up short; it is bounded by the stops' timeouts
        previous_sigint = signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        try:
            left = fleet.close()
        finally:
            signal.signal(signal.SIGINT, previous_sigint)
            signal.signal(signal.SIGTERM, previous_sigterm)
        assert not left, 'the clean-up left: ' + '; '.join(left)


# --- the observer on host a -----------------------------------------------------------------

def observe(ids, period_s=OBSERVER_PERIOD_S):
    """A ROS node printing, every period_s, one line `fleet {json}`: per vehicle its mavros/state,
    the z of its local_position/pose, the count of setpoint_position/local messages received and the
    monotonic time of the last; and the host of each of its nodes, as the master has them."""
    import rosgraph
    import rospy
    from urllib.parse import urlparse
    from geometry_msgs.msg import PoseStamped
    from mavros_msgs.msg import State

    rospy.init_node('fleet_observer', disable_signals=True)
    lock = threading.Lock()
    seen = {i: {'connected': False, 'armed': False, 'mode': '', 'z': None,
                'setpoints': 0, 'last_setpoint_s': None} for i in ids}

    def on_state(msg, i):
        with lock:
            seen[i].update(connected=msg.connected, armed=msg.armed, mode=msg.mode)

    def on_pose(msg, i):
        with lock:
            seen[i]['z'] = msg.pose.position.z

    def on_setpoint(msg, i):
        now = time.monotonic()
        with lock:
            seen[i]['setpoints'] += 1
            seen[i]['last_setpoint_s'] = now

    for i in ids:
        ns = '/uav%d/mavros/' % i
        rospy.Subscriber(ns + 'state', State, on_state, i)
        rospy.Subscriber(ns + 'local_position/pose', PoseStamped, on_pose, i)
        rospy.Subscriber(ns + 'setpoint_position/local', PoseStamped, on_setpoint, i)
    master = rosgraph.Master(rospy.get_name())
    node_hosts = {}
    wanted = ['/uav%d/%s' % (i, node) for i in ids for node in ROS_NODES]
    while True:
        for name in wanted:
            if name not in node_hosts:
                try:
                    node_hosts[name] = urlparse(master.lookupNode(name)).hostname
                except rosgraph.MasterError:
                    pass  # not registered yet
        with lock:
            line = json.dumps({'t': time.monotonic(), 'vehicles': seen, 'nodes': node_hosts})
        print(STATUS_PREFIX + line, flush=True)
        time.sleep(period_s)


class Observer:
    """The observer's process and its latest status line."""

    def __init__(self, fleet):
        ids = [str(VEHICLE_OF_HOST[h]) for h in HOSTS]
        self.proc = fleet.run('a', [sys.executable, os.path.abspath(__file__), 'observe'] + ids)

    def latest(self):
        """The newest status ({'t', 'vehicles': {id: ...}, 'nodes': {name: host}}), or None."""
        for line in reversed(self.proc.lines):
            if line.startswith(STATUS_PREFIX):
                status = json.loads(line[len(STATUS_PREFIX):])
                status['vehicles'] = {int(i): v for i, v in status['vehicles'].items()}
                return status
        return None


def hovering(vehicle):
    return (vehicle['connected'] and vehicle['armed'] and vehicle['mode'] == 'OFFBOARD'
            and vehicle['z'] is not None and abs(vehicle['z'] - TARGET_Z_M) <= HOVER_TOLERANCE_M)


def describe(status):
    """What the observer saw, vehicle by vehicle, for a failure message."""
    if status is None:
        return 'the observer has printed nothing yet'
    return '; '.join('uav%d: connected %s, armed %s, mode %r, z %s, %d setpoints seen'
                     % (i, v['connected'], v['armed'], v['mode'],
                        'none' if v['z'] is None else '%.2f m' % v['z'], v['setpoints'])
                     for i, v in sorted(status['vehicles'].items()))


def tails(procs, chars=1500):
    return '\n'.join('--- %s:\n%s' % (' '.join(p.args[3:]), p.output[-chars:]) for p in procs)


def wait_until(condition, timeout_s, period_s=0.2):
    """condition()'s first truthy value within timeout_s, else None."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(period_s)
    return condition() or None


# --- the test ---------------------------------------------------------------------------------

def test_one_vehicle_per_host_under_one_master(fleet, capsys):
    ids = [VEHICLE_OF_HOST[h] for h in HOSTS]
    master = fleet.start_master()
    t_master = time.monotonic()
    master.expect_line('started core service [/rosout]', MASTER_TIMEOUT_S)
    master_up_s = time.monotonic() - t_master

    t_launch = time.monotonic()
    launches = {h: fleet.run(h, ['roslaunch', 'offboard_py', 'multi_uav.launch', 'n:=1',
                                 'first:=%d' % VEHICLE_OF_HOST[h]])
                for h in HOSTS}
    observer = Observer(fleet)
    everyone = [master] + list(launches.values()) + [observer.proc]

    def all_hovering():
        for proc in everyone:
            if proc.proc.poll() is not None:
                raise AssertionError('%s exited (%s) before the fleet hovered; the observer saw: %s\n%s'
                                     % (' '.join(proc.args[3:]), proc.proc.returncode, describe(observer.latest()),
                                        tails(everyone)))
        status = observer.latest()
        return status if status and all(hovering(status['vehicles'][i]) for i in ids) else None

    first_hover = wait_until(all_hovering, HOVER_TIMEOUT_S)
    assert first_hover, ('the three vehicles were not all OFFBOARD, armed and at %.1f m +- %.1f m within %.0f s '
                         'of the launches; the observer (host a) saw: %s\n%s'
                         % (TARGET_Z_M, HOVER_TOLERANCE_M, HOVER_TIMEOUT_S, describe(observer.latest()),
                            tails(everyone)))
    hover_s = first_hover['t'] - t_launch

    # Each vehicle's nodes run on its own host: the master has them at that host's address. (The
    # simulator is no ROS node; its bridge reaches it on the host's own loopback, so it is there too.)
    for h in HOSTS:
        for node in ROS_NODES:
            name = '/uav%d/%s' % (VEHICLE_OF_HOST[h], node)
            registered = first_hover['nodes'].get(name)
            assert registered == fleet.address[h], (
                '%s is registered at %s, expected host %s (%s); all: %s'
                % (name, registered, h, fleet.address[h], first_hover['nodes']))

    # Hold: every status over HOLD_S still hovering; the setpoint rate from the counts at both ends.
    deadline = time.monotonic() + HOLD_S
    lowest = {i: first_hover['vehicles'][i]['z'] for i in ids}
    highest = dict(lowest)
    last = first_hover
    while time.monotonic() < deadline:
        time.sleep(OBSERVER_PERIOD_S)
        status = observer.latest()
        if status['t'] == last['t']:
            continue
        for i in ids:
            vehicle = status['vehicles'][i]
            assert hovering(vehicle), ('uav%d stopped hovering %.1f s after all hovered: %s'
                                       % (i, status['t'] - first_hover['t'], describe(status)))
            lowest[i] = min(lowest[i], vehicle['z'])
            highest[i] = max(highest[i], vehicle['z'])
        last = status
    assert last['t'] - first_hover['t'] >= HOLD_S - 2 * OBSERVER_PERIOD_S, (
        'the observer printed nothing for %.1f s of the %.0f s hold' % (HOLD_S - (last['t'] - first_hover['t']), HOLD_S))

    rates = {}
    for i in ids:
        before, after = first_hover['vehicles'][i], last['vehicles'][i]
        if before['last_setpoint_s'] is None or after['last_setpoint_s'] is None:
            rates[i] = 0.0  # none seen on host a
            continue
        span_s = after['last_setpoint_s'] - before['last_setpoint_s']
        rates[i] = (after['setpoints'] - before['setpoints']) / span_s if span_s > 0 else 0.0

    with capsys.disabled():
        print('\nfleet across 3 network-namespace hosts: master up in %.1f s; all 3 hovering %.1f s after '
              'the launches; over %.1f s of hover z %s; setpoint_position/local seen on host a at %s'
              % (master_up_s, hover_s, last['t'] - first_hover['t'],
                 ', '.join('uav%d %.2f..%.2f m' % (i, lowest[i], highest[i]) for i in ids),
                 ', '.join('uav%d %.2f Hz' % (i, rates[i]) for i in ids)), flush=True)

    for i in ids:
        assert abs(rates[i] - SETPOINT_RATE_HZ) <= RATE_TOLERANCE * SETPOINT_RATE_HZ, (
            "uav%d's setpoints reached host a at %.2f Hz over %.1f s, expected %.0f Hz +- %.0f %%"
            % (i, rates[i], last['t'] - first_hover['t'], SETPOINT_RATE_HZ, 100 * RATE_TOLERANCE))


if __name__ == '__main__':
    if sys.argv[1:2] != ['observe'] or len(sys.argv) < 3:
        sys.exit('usage: %s observe ID [ID ...]   (the observer node of test_fleet_netns)' % sys.argv[0])
    # Ctrl-C ends it even when started with SIGINT ignored (a test run in the background)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        observe([int(i) for i in sys.argv[2:]])
    except KeyboardInterrupt:
        pass
