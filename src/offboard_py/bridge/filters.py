"""Which FCU messages a plugin's handler is given: mavros's plugin filters (mavros/plugin_filter.h).

A handler declares its filter when it registers, `bridge.on('HEARTBEAT', handler, filters.COMPONENT)`,
instead of checking ids itself. Each filter is accept(msg, target_system, target_component).
Malformed frames never reach a handler (the link drops them), so mavros's "...AndOk" is the
link's part here.
"""


def ANY(_msg, _target_system, _target_component):
    """From anyone (mavros's AnyOk)."""
    return True


def SYSTEM(msg, target_system, _target_component):
    """From any component of the target system (mavros's SystemAndOk): the default."""
    return msg.get_srcSystem() == target_system


def COMPONENT(msg, target_system, target_component):
    """From the target system and component (mavros's ComponentAndOk): for HEARTBEAT, since a
    camera or gimbal of the same system sends its own."""
    return msg.get_srcSystem() == target_system and msg.get_srcComponent() == target_component
