"""PARAM_VALUE / PARAM_SET values on the wire, as PX4 sends them (bytewise encoding).

PX4 announces MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE: an integer parameter's
four bytes travel unchanged in the float field `param_value`, not converted to a float.
The simulated PX4 and the bridge both use this module, so they agree by construction.
"""

import struct

from offboard_py.dialect import mavlink

# The integer types; PX4 uses INT32 only, the others decode the same way (sign-extended
# from the low bytes would be wrong for UINT32, but PX4 never sends it).
INT_TYPES = frozenset((mavlink.MAV_PARAM_TYPE_UINT8, mavlink.MAV_PARAM_TYPE_INT8, mavlink.MAV_PARAM_TYPE_UINT16,
                       mavlink.MAV_PARAM_TYPE_INT16, mavlink.MAV_PARAM_TYPE_UINT32, mavlink.MAV_PARAM_TYPE_INT32))


def is_integer(param_type):
    return param_type in INT_TYPES


def encode(param_type, value):
    """The float that carries `value` in PARAM_VALUE/PARAM_SET for a parameter of `param_type`."""
    if param_type in INT_TYPES:
        return struct.unpack('<f', struct.pack('<i', int(value)))[0]
    return float(value)


def decode(param_type, wire_value):
    """The value a PARAM_VALUE/PARAM_SET float carries for a parameter of `param_type`."""
    if param_type in INT_TYPES:
        return struct.unpack('<i', struct.pack('<f', wire_value))[0]
    return float(wire_value)
