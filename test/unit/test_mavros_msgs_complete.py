"""mavros 1.21's own Python tools run on our mavros_msgs.

mavros's Python modules (mavros.command, mavros.mission, mavros.ftp, mavros.param, ...) and the scripts
built on them (mavsafety, mavcmd, mavwp, mavsetp, mavparam, mavftp, mavsys, checkid) import types from
mavros_msgs at load time: every name they import must be a definition of interfaces/mavros_msgs (or the
Request/Response half of one of its services), and must import from the generated package.

That every mavros_msgs 1.21 type is ours with upstream's md5 sum is test_interfaces_md5.py's
(test_all_of_mavros_msgs_1_21, against reference/mavros_msgs-1.21-md5.tsv).
"""

import importlib
import os
import re

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MAVROS_MSGS = os.path.join(REPO, 'interfaces', 'mavros_msgs')

# What each Python file of mavros 1.21 (github.com/mavlink/mavros, tag 1.21.0) imports from mavros_msgs,
# by its `from mavros_msgs.msg import ...` / `from mavros_msgs.srv import ...` lines. mavros/src/mavros/
# setpoint.py, nuttx_crc32.py and __init__.py, and the scripts mavsafety, mavcmd, mavwp, mavparam, mavftp
# and event_launcher import nothing from mavros_msgs themselves: they get it through the modules above.
MAVROS_IMPORTS = {
    'mavros/src/mavros/command.py': {
        'srv': ['CommandLong', 'CommandInt', 'CommandBool', 'CommandHome', 'CommandTOL',
                'CommandTriggerControl', 'CommandTriggerInterval']},
    'mavros/src/mavros/event_launcher.py': {'msg': ['State']},
    'mavros/src/mavros/ftp.py': {
        'msg': ['FileEntry'],
        'srv': ['FileOpen', 'FileClose', 'FileRead', 'FileList', 'FileOpenRequest', 'FileMakeDir',
                'FileRemoveDir', 'FileRemove', 'FileWrite', 'FileTruncate', 'FileRename', 'FileChecksum']},
    'mavros/src/mavros/mavlink.py': {'msg': ['Mavlink']},
    'mavros/src/mavros/mission.py': {
        'msg': ['Waypoint', 'WaypointList', 'CommandCode'],
        'srv': ['WaypointPull', 'WaypointPush', 'WaypointClear', 'WaypointSetCurrent']},
    'mavros/src/mavros/param.py': {
        'msg': ['ParamValue'],
        'srv': ['ParamPull', 'ParamPush', 'ParamGet', 'ParamSet']},
    'mavros/src/mavros/utils.py': {'msg': ['State']},
    'mavros/scripts/checkid': {'msg': ['Mavlink']},
    'mavros/scripts/mavsetp': {'srv': ['SetMode']},
    'mavros/scripts/mavsys': {
        'msg': ['State'],
        'srv': ['SetMode', 'StreamRate', 'StreamRateRequest', 'MessageInterval']},
}


def _definition(kind, name):
    """The definition file of interfaces/mavros_msgs that makes `name` of mavros_msgs.<kind>."""
    if kind == 'srv':
        for half in ('Request', 'Response'):
            if name.endswith(half) and len(name) > len(half):
                name = name[:-len(half)]
                break
    return os.path.join(MAVROS_MSGS, kind, '%s.%s' % (name, kind))


def test_every_name_mavros_imports_is_defined():
    missing = sorted('%s.%s (%s)' % (kind, name, source)
                     for source, imports in MAVROS_IMPORTS.items()
                     for kind, names in imports.items() for name in names
                     if not os.path.isfile(_definition(kind, name)))
    assert not missing, 'imported by mavros 1.21, not defined in interfaces/mavros_msgs: %s' % missing


def test_definitions_are_in_the_build():
    """Each of those definitions is listed in interfaces/mavros_msgs/CMakeLists.txt, so it is generated."""
    with open(os.path.join(MAVROS_MSGS, 'CMakeLists.txt')) as f:
        listed = set(re.findall(r'[A-Za-z0-9_]+\.(?:msg|srv)\b', f.read()))
    unlisted = sorted({os.path.basename(_definition(kind, name))
                       for imports in MAVROS_IMPORTS.values()
                       for kind, names in imports.items() for name in names} - listed)
    assert not unlisted, 'not in interfaces/mavros_msgs/CMakeLists.txt: %s' % unlisted


@pytest.mark.parametrize('source', sorted(MAVROS_IMPORTS))
def test_mavros_imports_work(source):
    """The import lines of `source`, run against the generated mavros_msgs (ours, or the system's)."""
    modules = {}
    for kind in MAVROS_IMPORTS[source]:
        try:
            modules[kind] = importlib.import_module('mavros_msgs.' + kind)
        except ImportError as e:
            pytest.skip('mavros_msgs.%s does not import (%s): build and source the workspace '
                        '(./run shell) to check the generated classes' % (kind, e))
    failed = sorted('%s.%s' % (kind, name) for kind, names in MAVROS_IMPORTS[source].items()
                    for name in names if not hasattr(modules[kind], name))
    assert not failed, '%s would fail to import from mavros_msgs (%s): %s' % (
        source, modules[next(iter(modules))].__file__, failed)
