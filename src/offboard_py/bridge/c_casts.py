"""What mavros's C++ casts make of numbers that do not fit the MAVLink field they go into.

mavros converts without checking: a ParamSet's int64 through static_cast<int>, a waypoint's
latitude * 1e7 through int32_t(double), a double into a float field. Python's struct refuses
such values, so the bridge converts them here first and sends what mavros sends, on x86-64
(the platform mavros's packages are built for). Pure functions.
"""

import math
import struct

INT32_MIN, INT32_MAX = -2 ** 31, 2 ** 31 - 1


def int32_from_int(value):
    """static_cast<int32_t> of a wider integer: its low 32 bits, two's complement (4294967297 -> 1)."""
    return ((int(value) - INT32_MIN) & 0xFFFFFFFF) + INT32_MIN


def int32_from_double(value):
    """int32_t(double): truncated toward zero; NaN or out of range gives x86's 'integer indefinite'
    (cvttsd2si), INT32_MIN."""
    if not math.isfinite(value):
        return INT32_MIN
    truncated = math.trunc(value)
    return truncated if INT32_MIN <= truncated <= INT32_MAX else INT32_MIN


def float32_from_double(value):
    """float(double): rounded to the nearest float; beyond the largest float, infinity of its sign."""
    try:
        return struct.unpack('<f', struct.pack('<f', value))[0]
    except OverflowError:
        return math.copysign(math.inf, value)
