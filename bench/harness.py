"""The bench harness: what every benchmark here shares (bench/benchmark.py, replay_bench.py, junk_flood.py),
in one module they import: the recorded figures they compare with, a master of their own, the processes of a
launch, the machine, the JSON and the table cells. No benchmark here imports another for these."""

import json
import os
import platform
import signal
import subprocess

import rosgraph

from offboard_py.master import MasterTimeout, wait_for_master


# Real mavros 1.21 and real PX4 SITL (SIH) hovering under the project's offb_node, % of one core, two runs each:
# reference/px4-sitl-measured.md, "Real mavros 1.21 beside our parts" (stack A)
MAVROS_CPU_PCT = (2.08, 2.33)
PX4_SITL_CPU_PCT = (9.77, 11.08)


def parent_pid(pid):
    try:
        return int(open('/proc/%s/stat' % pid).read().rsplit(')', 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return 0


def descends_from(pid, ancestor):
    """Whether process pid is ancestor's child, grandchild, ...: on a shared machine other launches' nodes
    run in the same namespaces (uav0 ...) and must not be counted."""
    pid = int(pid)
    while pid > 1:
        pid = parent_pid(pid)
        if pid == ancestor:
            return True
    return False


def forget_stale_nodes(prefixes=('/uav', '/sim_clock')):
    """Unregister from the master what nodes of a stopped launch left registered (a node killed
    before it could unregister). The master keeps such a registration with its old XML-RPC
    URI; when the next launch registers a node of the same name, the master tells that URI to
    shut down, and if another node of the new launch has been given the same port, that node
    is shut down instead ("new node registered with same name"; seen once at 24 vehicles).
    Returns the names unregistered."""
    master = rosgraph.Master('/benchmark_cleanup')
    pubs, subs, srvs = master.getSystemState()
    stale = sorted({node for group in (pubs, subs, srvs) for _, nodes in group for node in nodes
                    if node.startswith(prefixes)})
    for node in stale:
        as_node = rosgraph.Master(node)
        try:
            api = master.lookupNode(node)
            for topic, nodes in pubs:
                if node in nodes:
                    as_node.unregisterPublisher(topic, api)
            for topic, nodes in subs:
                if node in nodes:
                    as_node.unregisterSubscriber(topic, api)
            for service, nodes in srvs:
                if node in nodes:
                    as_node.unregisterService(service, master.lookupService(service))
        except rosgraph.MasterException:
            continue  # gone meanwhile
    return stale


def fmt(value, digits=1):
    return '-' if value is None else ('%.*f' % (digits, value))


def machine():
    """What the figures were measured on."""
    return {'cores': os.cpu_count(), 'cpu': platform.processor() or platform.machine(),
            'python': platform.python_version(), 'kernel': platform.release()}


def write_json(result, path):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, 'w') as out:
        json.dump(result, out, indent=2)
    print('JSON: %s' % os.path.abspath(path))


def start_master(logdir, fail):
    """A roscore unless a master is up (one master for every run: the measuring node must stay
    registered with it); None when one was up. fail(message) on a master that does not come up."""
    if rosgraph.is_master_online():
        return None
    core = subprocess.Popen(['roscore'], stdout=open(os.path.join(logdir, 'roscore.log'), 'w'),
                            stderr=subprocess.STDOUT, start_new_session=True)

    def master_up_or_roscore_gone():
        return rosgraph.is_master_online() or core.poll() is not None
    try:  # we start the master: no "is roscore running?" while it comes up
        wait_for_master('benchmark', 30.0, is_online=master_up_or_roscore_gone, say=lambda text: None)
    except MasterTimeout as err:
        fail('%s (see %s/roscore.log)' % (err, logdir))
    if core.poll() is not None:
        fail('roscore exited with code %s (see %s/roscore.log)' % (core.returncode, logdir))
    return core


def stop_master(core):
    if core is not None:
        os.killpg(core.pid, signal.SIGINT)
        try:
            core.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(core.pid, signal.SIGKILL)
