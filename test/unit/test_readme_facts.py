"""What the README says of the code, held to the code: the interface count, and ./run's commands (its usage
text, its dispatcher and the README's list name the same ones)."""

import os
import re
import subprocess

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')


def read(name):
    with open(os.path.join(ROOT, name)) as f:
        return f.read()


def test_the_readme_counts_the_mavros_msgs_interfaces():
    folder = os.path.join(ROOT, 'interfaces', 'mavros_msgs')
    count = sum(1 for sub in ('msg', 'srv') for name in os.listdir(os.path.join(folder, sub))
                if name.endswith('.' + sub))
    said = re.search(r'the (\d+) messages and services of mavros 1\.21', read('README.md'))
    assert said, 'the README no longer counts the interfaces'
    assert int(said.group(1)) == count, 'README says %s, interfaces/mavros_msgs has %d' % (said.group(1), count)


def dispatched():
    """The commands ./run's dispatcher takes (its `case "$cmd"` arms)."""
    text = read('run')
    block = text[text.index('case "$cmd" in'):]
    return set(re.findall(r'^  ([a-z]+)\)', block, re.M))


def test_run_lists_every_command_it_takes():
    usage = subprocess.run(['bash', os.path.join(ROOT, 'run')], stdin=subprocess.DEVNULL, capture_output=True,
                           text=True, timeout=30)
    assert usage.returncode == 2
    listed = set(re.findall(r'^\s*\./run ([a-z]+)', usage.stderr + usage.stdout, re.M))
    assert listed == dispatched(), 'usage lists %s; ./run takes %s' % (sorted(listed), sorted(dispatched()))


def test_the_readme_names_every_command():
    readme = read('README.md')
    named = set(re.findall(r'\./run ([a-z]+)', readme))
    assert dispatched() <= named, 'the README leaves out %s' % sorted(dispatched() - named)
