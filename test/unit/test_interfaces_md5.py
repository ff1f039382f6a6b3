"""The interface packages must be byte-for-byte compatible with upstream mavros_msgs.

ROS 1 checks the md5 sum of a type on every connection, so a bag or node built with
real mavros_msgs interoperates only if ours hash the same. The expected sums are the
upstream ones (../shared/reference/mavros-api.md and, for mavros_msgs 1.21,
../shared/reference/mavros_msgs-1.21-md5.tsv). Both the definition files
(through genmsg, as catkin does) and the generated Python classes are checked.
"""

import importlib
import os

import genmsg
import genmsg.gentools
import genmsg.msg_loader
import pytest
import rospkg

INTERFACES = os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', 'interfaces')

EXPECTED = {
    'mavros_msgs/State': '65cd0a9fff993b062b91e354554ec7e9',
    'mavros_msgs/ExtendedState': 'ae780b1800fe17b917369d21b90058bd',
    'mavros_msgs/PositionTarget': 'dedb0081aaf8cb20209737746bb49117',
    'mavros_msgs/Waypoint': 'f7090ce9f0c7ad0665de1ddadfd11ace',
    'mavros_msgs/WaypointList': '0605a2df153acd9a4a4823385ed81b57',
    'mavros_msgs/Altitude': '1296a05dc5b6160be0ae04ba9ed3a3fa',
    'mavros_msgs/HomePosition': 'c1167922de8c97acdb0ec714c1dba774',
    'mavros_msgs/ParamValue': 'e2cb1c7a0f6ef0c62d450cd9362c980d',
    'mavros_msgs/CommandBool': 'e09abbb4e5bae6b558e5010966eb6e9e',
    'mavros_msgs/SetMode': 'e4f18fa93379f9ff1780d270ce110203',
    'mavros_msgs/CommandTOL': '93ff4eaa9907f58c0e7a909cddce23e2',
    'mavros_msgs/ParamGet': '777d24d2a7ab1765ef009a69f464d2bc',
    'mavros_msgs/ParamSet': 'c423cafb898fff374cbe8530ecd4d285',
    'mavros_msgs/WaypointPush': '96690cb0f07ea4a54cdd6f188e10228e',
    'mavros_msgs/WaypointClear': '358e233cde0c8a8bcfea4ce193f8fc15',
    'mavros_msgs/Mavlink': '41093e1fd0f3eea1da2aa33a177e5ba6',
    'mavros_msgs/StatusText': '6cfd33cd09e4abf5841d7be3c770a969',
    'mavros_msgs/VFR_HUD': '1f55e210c3d39fe105d44d8dc963655f',
    'mavros_msgs/RCIn': '1c3eafdb5efbcda3c334e1788bbcfe39',
    'mavros_msgs/EstimatorStatus': '39dbcc4be3f04b68422f784827c47dd5',
    'mavros_msgs/AttitudeTarget': '456f3af666b22ccd0222ea053a86b548',
    'mavros_msgs/GlobalPositionTarget': '076ded0190b9e045f9c55264659ef102',
    'mavros_msgs/Thrust': 'c61da3a8868a8b502eaf0b0abd839f57',
    'mavros_msgs/TimesyncStatus': '021ec8044e747bea518b441f374ba64b',
    'mavros_msgs/CommandLong': 'eb9034afc87577c0a235d45b8f3437d2',
    'mavros_msgs/CommandInt': '5d5fd287bf3d27ad6ec508b1692f3b09',
    'mavros_msgs/MessageInterval': '99e633e185b7ee6b477bc9843a87b5ae',
    'mavros_msgs/StreamRate': 'd12f7661724c8ba25f67ba597bb7d039',
    'mavros_msgs/ParamPush': 'd3fc4d8cefa193382985a92a041a2a3d',
    'mavros_msgs/WaypointSetCurrent': 'f99aa1a911a80ab546ea470f4e90c807',
    'geographic_msgs/GeoPoint': 'c48027a852aeff972be80478ff38e81a',
}
SERVICES = {'CommandBool', 'SetMode', 'CommandTOL', 'ParamGet', 'ParamSet', 'WaypointPush', 'WaypointClear',
            'CommandLong', 'CommandInt', 'MessageInterval', 'StreamRate', 'ParamPush', 'WaypointSetCurrent'}


def _search_path():
    path = {pkg: [os.path.join(INTERFACES, pkg, 'msg')] for pkg in ('mavros_msgs', 'geographic_msgs')}
    for pkg in ('std_msgs', 'geometry_msgs'):
        try:
            share = rospkg.RosPack().get_path(pkg)
        except rospkg.ResourceNotFound:
            share = '/usr/share/' + pkg  # Debian's layout, when ROS_PACKAGE_PATH is unset
        path[pkg] = [os.path.join(share, 'msg')]
    return path


@pytest.mark.parametrize('full_name', sorted(EXPECTED))
def test_definition_md5(full_name):
    package, name = full_name.split('/')
    ctx = genmsg.MsgContext.create_default()
    if name in SERVICES:
        spec = genmsg.msg_loader.load_srv_from_file(
            ctx, os.path.join(INTERFACES, package, 'srv', name + '.srv'), full_name)
    else:
        spec = genmsg.msg_loader.load_msg_from_file(
            ctx, os.path.join(INTERFACES, package, 'msg', name + '.msg'), full_name)
    genmsg.msg_loader.load_depends(ctx, spec, _search_path())
    assert genmsg.gentools.compute_md5(ctx, spec) == EXPECTED[full_name]


@pytest.mark.parametrize('full_name', sorted(EXPECTED))
def test_generated_class_md5(full_name):
    """The classes nodes actually import (ours, or the system's real mavros_msgs)."""
    package, name = full_name.split('/')
    kind = 'srv' if name in SERVICES else 'msg'
    module = importlib.import_module('%s.%s' % (package, kind))
    assert getattr(module, name)._md5sum == EXPECTED[full_name]
