"""python -m offboard_py.conversation REFERENCE OURS [--png FILE] [--side ros|fcu|both]...

Compares two recordings of the FCU link (pcap or decoded JSONL, optionally .xz): prints the phases
and the differences (ours against the reference) and writes the PNG. Exit status 0 with no
differences, 1 with some, 2 when a recording cannot be read."""

import argparse
import sys

from offboard_py.conversation import analysis, compare, reading, report


def main(argv=None):
    p = argparse.ArgumentParser(prog='python -m offboard_py.conversation', description=__doc__.split('\n\n')[0])
    p.add_argument('reference', help='the recording held as the truth (e.g. reference/conversations/'
                                     'takeoff-mavros-px4.jsonl.xz)')
    p.add_argument('ours', help='the recording compared with it')
    p.add_argument('--png', help='write the rates and events to this PNG')
    p.add_argument('--table', help='also write the tables to this file')
    p.add_argument('--side', action='append', choices=('ros', 'fcu', 'both'),
                   help='only the figures of this side (repeatable; default all)')
    p.add_argument('--fcu-port', type=int, default=reading.FCU_PORT,
                   help='the FCU\'s UDP port in a pcap (default %(default)s)')
    args = p.parse_args(argv)
    summaries = []
    for path in (args.reference, args.ours):
        try:
            messages = reading.read(path, args.fcu_port)
        except reading.RecordingError as err:
            print('conversation: %s' % err, file=sys.stderr)
            return 2
        if not messages:
            print('conversation: %s: no MAVLink messages on port %d' % (path, args.fcu_port), file=sys.stderr)
            return 2
        summaries.append(analysis.Summary(messages, path.rsplit('/', 1)[-1]))
    differences = compare.compare(summaries[0], summaries[1], tuple(args.side or ('ros', 'fcu', 'both')))
    text = '\n'.join(report.phase_table(summaries) + [''] + report.difference_table(
        differences, title='differences of %s from %s' % (summaries[1].name, summaries[0].name)))
    print(text)
    if args.table:
        try:
            with open(args.table, 'w') as out:
                out.write(text + '\n')
        except OSError as err:
            print('conversation: --table %s: %s' % (args.table, err.strerror), file=sys.stderr)
            return 2
    if args.png:
        report.plot(summaries, args.png)
        print('\nwrote %s' % args.png)
    return 1 if differences else 0


if __name__ == '__main__':
    sys.exit(main())
