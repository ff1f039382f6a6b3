"""The simulated PX4's message builders are reached through one explicit table, name -> method
(sim.mavlink.messages.TelemetryBuilder.BUILDERS): every message a stream or a request can ask for has
its builder there, and a name without one is a clear error, not a helper's method called by accident."""

import pytest

from offboard_py.dialect import mavlink
from offboard_py.sim.mavlink import messages, streams


def test_every_builder_is_the_method_of_its_message_name():
    for name, builder in messages.TelemetryBuilder.BUILDERS.items():
        assert builder.__name__ == '_' + name.lower(), name
        assert getattr(mavlink, 'MAVLINK_MSG_ID_' + name, None) is not None, name


def test_every_stream_and_requested_message_has_a_builder():
    wanted = (streams.STREAMABLE | streams.ON_REQUEST) - streams.PER_LINK
    assert wanted <= set(messages.TelemetryBuilder.BUILDERS), wanted - set(messages.TelemetryBuilder.BUILDERS)


@pytest.mark.parametrize('name', ['NO_SUCH_MESSAGE', 'GLOBAL', 'EULER', 'heartbeat', 'LINK_NODE_STATUS'])
def test_a_name_without_a_builder_is_a_clear_error(name):
    builder = messages.TelemetryBuilder(mavlink.MAVLink(None, srcSystem=1), None, {})
    with pytest.raises(ValueError, match=repr(name)):
        builder.build(name, None, 0.0)
