"""The interface packages must be byte-for-byte compatible with upstream mavros_msgs.

ROS 1 checks the md5 sum of a type on every connection, so a bag or node built with
real mavros_msgs interoperates only if ours hash the same. The expected sums are the
upstream ones: real mavros_msgs 1.21's (reference/mavros_msgs-1.21-md5.tsv, from a real build) and
upstream geographic_msgs's GeoPoint. Both the definition files
(through genmsg, as catkin does) and the generated Python classes are checked, and our mavros_msgs
must hold all of upstream's 1.21 (every type of the tsv, none missing).
"""

import importlib
import os

import genmsg
import genmsg.gentools
import genmsg.msg_loader
import pytest
import rospkg

INTERFACES = os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', 'interfaces')

REFERENCE = os.path.join(os.path.dirname(INTERFACES), 'reference', 'mavros_msgs-1.21-md5.tsv')


def _upstream_md5s():
    """type -> md5 of real mavros_msgs 1.21 (reference/mavros_msgs-1.21-md5.tsv: kind, type, md5)."""
    with open(REFERENCE) as f:
        rows = [line.rstrip('\n').split('\t') for line in f][1:]
    return {full_name: md5 for _, full_name, md5 in rows}


def _ours():
    """(full name, kind) of every definition in our interface packages."""
    found = []
    for package in ('mavros_msgs', 'geographic_msgs'):
        for kind in ('msg', 'srv'):
            folder = os.path.join(INTERFACES, package, kind)
            for name in sorted(os.listdir(folder)) if os.path.isdir(folder) else ():
                found.append(('%s/%s' % (package, os.path.splitext(name)[0]), kind))
    return found


UPSTREAM = _upstream_md5s()
# geographic_msgs is not mavros_msgs: the sums are upstream geographic_msgs's (ROS 1), of its definitions
# (GeoPoint: float64 latitude, longitude, altitude; GeoPose: GeoPoint position, geometry_msgs/Quaternion
# orientation; GeoPoseStamped: Header header, GeoPose pose), the same as the generated code of other
# projects carries for these types
EXPECTED = dict(UPSTREAM, **{'geographic_msgs/GeoPoint': 'c48027a852aeff972be80478ff38e81a',
                             'geographic_msgs/GeoPose': '778680b5172de58b7c057d973576c784',
                             'geographic_msgs/GeoPoseStamped': 'cc409c8ed6064d8a846fa207bf3fba6b'})
OURS = _ours()
SERVICES = {full_name.split('/')[1] for full_name, kind in OURS if kind == 'srv'}


def test_every_definition_of_ours_is_an_upstream_one():
    assert len(OURS) >= 33, OURS
    missing = [full_name for full_name, _ in OURS if full_name not in EXPECTED]
    assert not missing, 'not in mavros_msgs 1.21 (reference/mavros_msgs-1.21-md5.tsv): %s' % missing


def _search_path():
    path = {pkg: [os.path.join(INTERFACES, pkg, 'msg')] for pkg in ('mavros_msgs', 'geographic_msgs')}
    for pkg in ('std_msgs', 'geometry_msgs'):
        try:
            share = rospkg.RosPack().get_path(pkg)
        except rospkg.ResourceNotFound:
            share = '/usr/share/' + pkg  # Debian's layout, when ROS_PACKAGE_PATH is unset
        path[pkg] = [os.path.join(share, 'msg')]
    return path


def _definition_md5(full_name, kind):
    """md5 of one of our definition files, as genmsg computes it for the build."""
    package, name = full_name.split('/')
    ctx = genmsg.MsgContext.create_default()
    if kind == 'srv':
        spec = genmsg.msg_loader.load_srv_from_file(
            ctx, os.path.join(INTERFACES, package, 'srv', name + '.srv'), full_name)
    else:
        spec = genmsg.msg_loader.load_msg_from_file(
            ctx, os.path.join(INTERFACES, package, 'msg', name + '.msg'), full_name)
    genmsg.msg_loader.load_depends(ctx, spec, _search_path())
    return genmsg.gentools.compute_md5(ctx, spec)


@pytest.mark.parametrize('full_name', sorted(n for n, _ in OURS))
def test_definition_md5(full_name):
    kind = 'srv' if full_name.split('/')[1] in SERVICES else 'msg'
    assert _definition_md5(full_name, kind) == EXPECTED[full_name]


def test_all_of_mavros_msgs_1_21():
    """Every msg and srv of mavros_msgs 1.21 is ours, of the same kind, with upstream's md5 sum."""
    with open(REFERENCE) as f:
        rows = [line.rstrip('\n').split('\t') for line in f][1:]
    assert len(rows) == 124, 'reference/mavros_msgs-1.21-md5.tsv: %d rows, not 79 msg + 45 srv' % len(rows)
    ours = dict(OURS)
    missing = sorted('%s (%s)' % (full_name, kind) for kind, full_name, _ in rows if ours.get(full_name) != kind)
    differ = sorted(full_name for kind, full_name, md5 in rows
                    if ours.get(full_name) == kind and _definition_md5(full_name, kind) != md5)
    assert not missing and not differ, 'not in interfaces/mavros_msgs: %s; md5 differs from upstream: %s' % (
        missing or 'none', differ or 'none')


@pytest.mark.parametrize('full_name', sorted(n for n, _ in OURS))
def test_generated_class_md5(full_name):
    """The classes nodes actually import (ours, or the system's real mavros_msgs)."""
    package, name = full_name.split('/')
    kind = 'srv' if name in SERVICES else 'msg'
    module = importlib.import_module('%s.%s' % (package, kind))
    assert getattr(module, name)._md5sum == EXPECTED[full_name]
