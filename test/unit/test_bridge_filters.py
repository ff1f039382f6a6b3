"""The handler filters: which sender each one lets through, as mavros's plugin filters."""

import pytest

from offboard_py.bridge import filters
from offboard_py.dialect import mavlink

TARGET = (1, 1)


def from_sender(system, component):
    """A HEARTBEAT as the bridge's handlers get it: parsed, with its sender's ids."""
    codec = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
    data = codec.heartbeat_encode(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 0).pack(codec)
    return mavlink.MAVLink(None).parse_buffer(data)[0]


@pytest.mark.parametrize('sender, any_, system, component', [
    ((1, 1), True, True, True),                                # the autopilot
    ((1, mavlink.MAV_COMP_ID_CAMERA), True, True, False),      # its camera
    ((2, 1), True, False, False),                              # another vehicle
])
def test_each_filter_lets_through_its_senders(sender, any_, system, component):
    msg = from_sender(*sender)
    assert [filters.ANY(msg, *TARGET), filters.SYSTEM(msg, *TARGET), filters.COMPONENT(msg, *TARGET)] == [
        any_, system, component]
