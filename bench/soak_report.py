"""The soak's report: the tables printed at the end, the JSON and the PNG (bench/soak.py)."""

import json
import os
import platform
import sys

from offboard_py.tools import soak_rules as soak


def plot(run, path):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    with run.monitor.lock:
        poses, states = list(run.monitor.poses), list(run.monitor.states)
    watches = run.monitor.watches
    fig, (ax_z, ax_mode, ax_rss) = plt.subplots(3, 1, figsize=(12, 9), dpi=100, sharex=True,
                                               gridspec_kw={'height_ratios': [3, 2, 2]})

    def minutes(t):
        return t / 60.0
    ax_z.axhspan(soak.TARGET_Z_M - soak.RECOVERY_TOLERANCE_M, soak.TARGET_Z_M + soak.RECOVERY_TOLERANCE_M,
                 color='tab:green', alpha=0.15, label='2 m +- %.1f m' % soak.RECOVERY_TOLERANCE_M)
    xs, zs = [], []
    for i, (t, z) in enumerate(poses):  # no line across a gap in the poses (a bridge restarting)
        if i and t - poses[i - 1][0] > 1.0:
            xs.append(float('nan'))
            zs.append(float('nan'))
        xs.append(minutes(t))
        zs.append(z)
    ax_z.plot(xs, zs, color='tab:blue', lw=0.8, label='altitude z (ENU)')
    top = max([z for _, z in poses] + [2.5])
    for w in watches:
        end = w.end_s if w.end_s is not None else w.start_s
        for ax in (ax_z, ax_mode):
            ax.axvspan(minutes(w.start_s), minutes(max(end, w.start_s + 1.0)), color='tab:red', alpha=0.25)
            if w.recovered_s is not None:
                ax.axvline(minutes(w.recovered_s), color='tab:green', lw=0.8, ls=':')
        ax_z.text(minutes(w.start_s), top * 1.02, '%d %s' % (w.fault.index, w.fault.kind), rotation=90,
                  va='bottom', ha='right', fontsize=7)
    ax_z.set_ylim(min([-0.1] + [z for _, z in poses]), top * 1.45)
    ax_z.set_ylabel('altitude (m)')
    ax_z.legend(loc='lower left', fontsize=8)
    ax_z.set_title('soak: %g simulated min at %gx, seed %d; faults shaded red, recoveries dotted green'
                   % (run.args.minutes, run.args.speed, run.args.seed))
    modes = ['no FCU'] + sorted({m or 'unknown' for _, c, m, _ in states if c and m != 'OFFBOARD'}) + ['OFFBOARD']

    def level(connected, mode):
        return modes.index((mode or 'unknown') if connected else 'no FCU')
    if states:
        last = max(states[-1][0], poses[-1][0] if poses else 0.0)
        ts = [minutes(t) for t, *_ in states] + [minutes(last)]
        ys = [level(c, m) for _, c, m, _ in states]
        ax_mode.step(ts, ys + ys[-1:], where='post', color='tab:purple', lw=1, label='mode')
        armed = [(minutes(t), 1 if a and c else 0) for t, c, _, a in states]
        ax_mode.step([a for a, _ in armed] + ts[-1:], [len(modes) - 0.6 + 0.3 * b for _, b in armed] + [
            len(modes) - 0.6 + 0.3 * armed[-1][1]], where='post', color='tab:orange', lw=1, label='armed (high)')
    ax_mode.set_yticks(list(range(len(modes))) + [len(modes) - 0.6, len(modes) - 0.3])
    ax_mode.set_yticklabels(modes + ['disarmed', 'armed'], fontsize=8)
    ax_mode.set_ylim(-0.5, len(modes) + 0.1)
    ax_mode.legend(loc='lower left', fontsize=8)
    colours = {'node': 'tab:blue', 'bridge': 'tab:orange', 'sim': 'tab:green'}
    by_process = {}
    for t, role, pid, rss in run.rss_samples:
        if rss is not None:
            by_process.setdefault((role, pid), []).append((minutes(t), rss))
    labelled = set()
    for (role, pid), points in by_process.items():
        ax_rss.plot([p[0] for p in points], [p[1] for p in points], color=colours[role], lw=1,
                    label=None if role in labelled else role)
        labelled.add(role)
    ax_rss.set_ylabel('RSS (MB)')
    ax_rss.set_xlabel('simulated time (min)')
    ax_rss.legend(loc='upper left', fontsize=8)
    for ax in (ax_z, ax_mode, ax_rss):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def report(run, stopped, wall_s, conn_timeout_s, lag_limit_s):
    """Print the tables, write the JSON and the PNG; return the reasons the soak failed."""
    m = run.monitor
    rows = soak.rss_growth(run.rss_samples)
    reasons = soak.verdict(m.watches, rows, m.lapses, stopped, m.startup)
    if m.startup.recovered_s is not None:
        print('\nhover after the start-up at %.1f s' % m.startup.recovered_s)
    print('\nfaults (simulated s since the launch; recovered: connected, OFFBOARD, armed, 2 m +- %.1f m, '
          'within %.0f s of the fault\'s end):' % (soak.RECOVERY_TOLERANCE_M, soak.RECOVERY_BOUND_S))
    print('\n'.join(soak.fault_table(m.watches)))
    print('\nRSS per process (growth after its first minute; a respawned process is a new one):')
    print('\n'.join(soak.rss_table(rows)))
    if m.lapses:
        print('\nhover lost with no fault under way: %s' % ', '.join('%.1f s (%s)' % lapse for lapse in m.lapses))
    if run.args.speed != 1.0:
        print('\nclock: the soak\'s own ROS time (/clock) trailed the vehicles\' clock by at most %.2f s (at %s s); '
              'more than %.1f s for %.1f simulated s in all' % (run.worst_lag_s, _fmt(run.worst_lag_at_s),
                                                                lag_limit_s, run.lagging_s))
    print('wall time %.0f s for %.1f simulated min at %gx' % (wall_s, (run.now() if run.t0 is not None else 0.0) / 60.0,
                                                             run.args.speed))
    png = os.path.splitext(run.args.out)[0] + '.png'
    result = {
        'command': ' '.join(sys.argv),
        'machine': {'cores': os.cpu_count(), 'python': platform.python_version(), 'kernel': platform.release()},
        'config': {'minutes': run.args.minutes, 'speed': run.args.speed, 'seed': run.args.seed,
                   'instance': run.args.instance, 'conn_timeout_s': conn_timeout_s,
                   'recovery_bound_s': soak.RECOVERY_BOUND_S, 'recovery_tolerance_m': soak.RECOVERY_TOLERANCE_M,
                   'settle_s': soak.SETTLE_S, 'rss_limit_mb': soak.RSS_LIMIT_MB,
                   'startup_bound_s': run.startup_bound_s, 'respawn_bound_s': run.respawn_bound_s},
        'schedule': [f.as_dict() for f in run.schedule],
        'startup': m.startup.as_dict(),
        'faults': [w.as_dict() for w in m.watches],
        'lapses': m.lapses,
        'rss': rows,
        'rss_samples': run.rss_samples,
        'minute_lines': run.minute_lines,
        'clock': {'worst_lag_s': run.worst_lag_s, 'worst_lag_at_s': run.worst_lag_at_s,
                  'lagging_s': run.lagging_s, 'lag_limit_s': lag_limit_s},
        'altitude_1hz': _every(m.poses, 1.0),
        'states': m.states,
        'wall_s': wall_s,
        'simulated_s': run.now() if run.t0 is not None else 0.0,
        'passed': not reasons,
        'reasons': reasons,
        'png': os.path.abspath(png),
        'launch_log': os.path.abspath(run.args.log),
    }
    with open(run.args.out, 'w') as out:
        json.dump(result, out, indent=1)
    try:
        plot(run, png)
        print('PNG: %s' % os.path.abspath(png))
    except Exception as err:  # the figures are in the JSON; a plot failure must not hide the verdict
        print('no PNG (%s: %s)' % (type(err).__name__, err))
    print('JSON: %s' % os.path.abspath(run.args.out))
    return reasons


def _fmt(value, digits=1):
    return '-' if value is None else '%.*f' % (digits, value)


def _every(points, period_s):
    out, next_t = [], None
    for t, z in points:
        if next_t is None or t >= next_t:
            out.append((round(t, 2), round(z, 3)))
            next_t = t + period_s
    return out
