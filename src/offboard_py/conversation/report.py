"""The comparison shown: a text table of the differences, the phases and events of each recording,
and a PNG (rates side by side per phase, events on a time line). matplotlib with the Agg backend, so
no display is needed."""

from offboard_py.conversation.compare import side_of

SIDE_NAMES = {'ros': 'ROS side -> FCU', 'fcu': 'FCU -> ROS side', 'both': 'flight'}


def _cell(value, width):
    text = 'absent' if value is None else str(value)
    return text if len(text) <= width else text[:width - 1] + '~'


def difference_table(differences, accepted=(), title='differences'):
    """Lines: the differences grouped by side, then the accepted ones with their reasons."""
    lines = []
    width = max([len(d.key) for d in differences] + [len(d.key) for d, _ in accepted] + [20])
    head = '%-*s  %-22s  %-22s  %s' % (width, 'figure', 'reference', 'ours', 'how')
    lines.append('%s: %d' % (title, len(differences)))
    for side in ('both', 'ros', 'fcu'):
        rows = [d for d in differences if side_of(d.key) == side]
        if not rows:
            continue
        lines.append('')
        lines.append('-- %s (%d)' % (SIDE_NAMES[side], len(rows)))
        lines.append(head)
        for d in rows:
            lines.append('%-*s  %-22s  %-22s  %s' % (width, d.key, _cell(d.reference, 22), _cell(d.ours, 22), d.why))
    if accepted:
        lines.append('')
        lines.append('accepted differences: %d' % len(accepted))
        for d, reason in accepted:
            lines.append('%-*s  %-22s  %-22s  %s' % (width, d.key, _cell(d.reference, 22), _cell(d.ours, 22), reason))
    return lines


def phase_table(summaries):
    """Lines: each recording's phases (start, length) side by side, and its anchors."""
    lines = ['%-12s' % 'phase' + ''.join('  %-24s' % s.name[:24] for s in summaries)]
    names = []
    for s in summaries:
        for p in s.phases:
            if p.name not in names:
                names.append(p.name)
    for name in names:
        row = '%-12s' % name
        for s in summaries:
            p = next((p for p in s.phases if p.name == name), None)
            row += '  %-24s' % ('missing' if p is None else '%7.2f s for %6.2f s' % (p.start, p.duration))
        lines.append(row)
    for anchor in ('connected', 'first setpoint', 'last setpoint'):
        row = '%-12s' % anchor[:12]
        for s in summaries:
            at = s.anchors.get(anchor)
            row += '  %-24s' % ('never' if at is None else 'at %.2f s' % at)
        lines.append(row)
    return lines


def plot(summaries, path, phase='armed hover'):
    """A PNG at `path`: per direction, each recording's rates in `phase` side by side (log scale), and
    every recording's events on a time line from its connection. Returns the path."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(15, 15), gridspec_kw={'height_ratios': [3, 1.4, 2.2]})
    for ax, direction in zip(axes[:2], ('fcu', 'ros')):
        kinds = sorted(set(k for s in summaries for (d, p, k) in s.rates if d == direction and p == phase))
        width = 0.8 / max(1, len(summaries))
        for i, s in enumerate(summaries):
            values = [s.rates.get((direction, phase, k), 0.0) for k in kinds]
            ax.bar([x + i * width for x in range(len(kinds))], values, width, label=s.name)
        ax.set_xticks([x + 0.4 - width / 2 for x in range(len(kinds))])
        ax.set_xticklabels(kinds, rotation=60, ha='right', fontsize=7)
        ax.set_yscale('log')
        ax.set_ylabel('messages/s')
        ax.set_title('%s, phase %s' % (SIDE_NAMES[direction], phase))
        ax.legend(fontsize=8)
        ax.grid(axis='y', alpha=0.3)
    ax = axes[2]
    colours = ['#dde8f5', '#f5e6dd', '#e0f0dc', '#efe0f0', '#f5f1d0', '#e6e6e6']
    for row, s in enumerate(summaries):
        zero = s.anchors.get('connected') or 0.0
        for i, p in enumerate(s.phases):
            ax.axvspan(p.start - zero, p.end - zero, ymin=(row + 0.05) / len(summaries),
                       ymax=(row + 0.95) / len(summaries), color=colours[i % len(colours)])
            ax.text(p.start - zero, row + 0.9, p.name, fontsize=7, va='top')
        for j, (t, direction, text) in enumerate(s.events):
            y = row + 0.15 + 0.6 * ((j % 6) / 6.0)
            ax.plot(t - zero, y, 'v' if direction == 'fcu' else '^', color='C1' if direction == 'fcu' else 'C0',
                    markersize=4)
            ax.text(t - zero, y + 0.02, text, fontsize=5, rotation=30)
    ax.set_ylim(0, len(summaries))
    ax.set_yticks([r + 0.5 for r in range(len(summaries))])
    ax.set_yticklabels([s.name for s in summaries], fontsize=8)
    ax.set_xlabel('s after the connection (the FCU\'s first HEARTBEAT once the ROS side speaks); '
                  '^ ROS side, v FCU')
    ax.set_title('phases and events')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
