"""The one table of SITL instances (offboard_py.testing.ports.INSTANCES) is what the code uses, and what
docs/testing.md shows: every instance CMakeLists.txt gives a rostest, every .test default, the soak's, the
example packages' (their CMakeLists.txt and example_workspace.TESTS) and the cross-stack tier's."""

import glob
import os
import re

from offboard_py.testing import cross_stack, example_workspace, ports

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))


def read(*path):
    with open(os.path.join(REPO, *path)) as f:
        return f.read()


def rows_with(n, word):
    return [who for first, last, who in ports.INSTANCES if first <= n <= last and word in who]


def test_every_registered_rostest_instance_is_in_the_table():
    registered = [(name, int(n)) for name, n in re.findall(r'\b(\w+):(\d+)\b', read('CMakeLists.txt'))]
    registered += [('', int(n)) for n in re.findall(r'instance:=(\d+)', read('CMakeLists.txt'))]
    assert len(registered) > 15
    for name, n in registered:
        assert rows_with(n, 'rostest'), 'CMakeLists.txt gives a rostest instance %d, which no row of the table has' % n
        assert n != 15 or name == 'conversation', \
            '%s on instance 15: its bridge port 14555 is mavros\'s default ground-station port' % name
    for scenario, (_, instance, _) in cross_stack.SCENARIOS.items():
        assert rows_with(instance, 'rostest'), scenario


def test_every_test_file_default_is_the_by_hand_row():
    defaults = []
    for path in glob.glob(os.path.join(REPO, 'test', 'rostest', '*.test')) + \
            glob.glob(os.path.join(REPO, 'examples', '*', 'test', '*.test')):
        with open(path) as f:
            found = re.search(r'<arg name="instance" default="(\d+)"', f.read())
        if found:
            defaults.append((os.path.basename(path), int(found.group(1))))
    assert len(defaults) > 10
    for name, n in defaults:
        assert rows_with(n, 'by hand'), '%s defaults to instance %d, not a by-hand row of the table' % (name, n)
    assert rows_with(int(re.search(r'<arg name="instance" default="(\d+)"', read('launch', 'soak.launch')).group(1)),
                     'soak')


def test_the_examples_instances_are_theirs_in_the_table():
    for package, test_file, n in example_workspace.TESTS:
        cmake = read('examples', package, 'CMakeLists.txt')
        assert 'add_rostest(test/%s ARGS instance:=%d)' % (test_file, n) in cmake, (package, test_file, n)
        assert rows_with(n, 'example'), (package, test_file, n)
    for n in ports.PYTEST_INSTANCES:
        assert rows_with(n, 'pytest'), n


def test_the_docs_show_the_table():
    docs = read('docs', 'testing.md')
    for first, last, who in ports.INSTANCES:
        span = '%d' % first if first == last else '%d-%d' % (first, last)
        assert '| %s | %s |' % (span, who) in docs, 'docs/testing.md lacks the row %s' % span
