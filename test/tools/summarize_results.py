"""Summarize the JUnit files that `catkin_make run_tests` leaves in build/test_results.

Prints one line per test case that did not pass, then a closing line
`N passed, N failed, N skipped`; exits 1 when a test failed or none ran.
Usage: summarize_results.py RESULTS_DIR
"""

import os
import sys
import xml.etree.ElementTree as ET


def collect(results_dir):
    cases = []
    for folder, _dirs, files in os.walk(results_dir):
        for name in sorted(files):
            if not name.endswith('.xml'):
                continue
            path = os.path.join(folder, name)
            try:
                root = ET.parse(path).getroot()
            except ET.ParseError as err:
                cases.append((path, 'unreadable results file', 'failed', str(err)))
                continue
            for case in root.iter('testcase'):
                label = '%s: %s.%s' % (name, case.get('classname', ''), case.get('name', ''))
                outcome, detail = 'passed', ''
                for tag in ('failure', 'error'):
                    node = case.find(tag)
                    if node is not None:
                        outcome, detail = 'failed', (node.get('message') or node.text or '').strip()
                if case.find('skipped') is not None:
                    node = case.find('skipped')
                    outcome, detail = 'skipped', (node.get('message') or node.text or '').strip()
                cases.append((path, label, outcome, detail))
    return cases


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    cases = collect(argv[1])
    counts = {'passed': 0, 'failed': 0, 'skipped': 0}
    for _path, label, outcome, detail in cases:
        counts[outcome] += 1
        if outcome != 'passed':
            print('%s %s %s' % (outcome.upper(), label, detail.splitlines()[0] if detail else ''))
    print('%d passed, %d failed, %d skipped' % (counts['passed'], counts['failed'], counts['skipped']))
    if not cases:
        print('no test results found in %s' % argv[1], file=sys.stderr)
    return 1 if counts['failed'] or not cases else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
