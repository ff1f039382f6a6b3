"""What /proc says of a process, for the benchmarks (no ROS): its CPU seconds and its wake-ups."""

import os

CLK_TCK = os.sysconf('SC_CLK_TCK')


def cpu_split_seconds(pid):
    """(user, system) CPU seconds of a process, all its threads."""
    with open('/proc/%d/stat' % pid) as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return int(fields[11]) / CLK_TCK, int(fields[12]) / CLK_TCK


def cpu_seconds(pid):
    """CPU seconds (user + system) of a process, all its threads."""
    return sum(cpu_split_seconds(pid))


def wakeups(pid):
    """Context switches (voluntary + involuntary) of all the process's threads: each is a wake-up or a
    preemption; a sleeping thread woken by a datagram counts one voluntary switch when it sleeps again."""
    total = 0
    for tid in os.listdir('/proc/%d/task' % pid):
        try:
            with open('/proc/%d/task/%s/status' % (pid, tid)) as f:
                total += sum(int(line.split()[1]) for line in f
                             if line.startswith(('voluntary_ctxt_switches', 'nonvoluntary_ctxt_switches')))
        except OSError:
            continue
    return total
