"""Waiting for the ROS master before rospy.init_node, saying so clearly.

rospy itself retries registration forever after one terse line, and an interrupted
wait ends in a traceback. Our nodes say which master they wait for, remind every
10 s, and stop cleanly on Ctrl-C. `_master_timeout:=SECONDS` on the command line
(read here, as no parameter server exists yet) bounds the wait; 0 waits forever.
"""

import math
import sys
import time

import rosgraph

REMIND_PERIOD_S = 10.0
POLL_PERIOD_S = 0.5


class MasterTimeout(Exception):
    """No master within _master_timeout; the message says where it was looked for."""


def master_timeout_from_argv(argv):
    """The `_master_timeout:=SECONDS` argument (0 if absent). Raises ValueError naming it."""
    for arg in argv:
        if arg.startswith('_master_timeout:='):
            text = arg.split(':=', 1)[1]
            try:
                value = float(text)
            except ValueError:
                value = float('nan')
            if not math.isfinite(value) or value < 0.0:
                raise ValueError('argument _master_timeout:=%s: expected seconds >= 0 (0: wait forever)' % text)
            return value
    return 0.0


def master_online():
    """True if the master answers. rosgraph.is_master_online() would do, but its bare `except:`
    also swallows the KeyboardInterrupt of a Ctrl-C that lands during the call, and the wait
    then goes on as if nothing had happened."""
    try:
        rosgraph.Master('/offboard_py_master_wait').getPid()
    except Exception:  # refused, timed out, an error answer: not online (yet)
        return False
    return True


def wait_for_master(node_name, timeout_s=0.0, is_online=master_online, say=None,
                    clock=time.monotonic, sleep=time.sleep):
    """Return once the master answers; raise MasterTimeout after timeout_s (0: never)."""
    if is_online():
        return
    say = say or (lambda text: print(text, file=sys.stderr, flush=True))
    uri = rosgraph.get_master_uri()
    start = last_said = clock()
    say('%s: no ROS master at %s (is roscore running?); waiting for it%s'
        % (node_name, uri, ' for up to %.0f s' % timeout_s if timeout_s else ''))
    while not is_online():
        now = clock()
        if timeout_s and now - start >= timeout_s:
            raise MasterTimeout('%s: no ROS master at %s after %.0f s; start roscore, or check ROS_MASTER_URI'
                                % (node_name, uri, now - start))
        if now - last_said >= REMIND_PERIOD_S:
            say('%s: still waiting for the ROS master at %s (%.0f s)' % (node_name, uri, now - start))
            last_said = now
        sleep(POLL_PERIOD_S)
    say('%s: ROS master found at %s' % (node_name, uri))


def await_master_from_argv(node_name, argv=None):
    """What a node's main() does first: wait for the master, bounded by `_master_timeout:=` in argv.
    None once the master answers; else the exit code, having said why (2: a bad _master_timeout,
    1: no master in time, 0: Ctrl-C while waiting)."""
    try:
        wait_for_master(node_name, master_timeout_from_argv(sys.argv if argv is None else argv))
    except (ValueError, MasterTimeout) as err:
        print(err, file=sys.stderr)
        return 2 if isinstance(err, ValueError) else 1
    except KeyboardInterrupt:
        return 0
    return None
