"""Offboard input of the simulated PX4: the three setpoint messages PX4 takes as the offboard signal
(SET_POSITION_TARGET_LOCAL_NED, SET_POSITION_TARGET_GLOBAL_INT, SET_ATTITUDE_TARGET) -> a vehicle Setpoint.

SET_POSITION_TARGET_LOCAL_NED, as PX4 reads it (reference/px4-behaviour.md and px4-sitl-measured.md;
PX4's mavlink_receiver.cpp where they are silent):
- frames LOCAL_NED and BODY_NED; BODY_NED rotates velocity and acceleration by the
  vehicle's yaw and ignores position, and drops the whole velocity (or acceleration) when
  any of its axes is ignored, as PX4 does; any other frame is refused;
- each axis whose POSITION_TARGET_TYPEMASK_*_IGNORE bit is set is left uncontrolled;
- the FORCE bit is taken as a normal setpoint when acceleration is ignored anyway
  (measured on PX4 SITL) and refused when it would make an acceleration a force;
- a message that controls no position, velocity or acceleration is refused, and so is
  an infinite number anywhere.
SET_POSITION_TARGET_GLOBAL_INT: the position (all three axes or none) projected around the estimator's
origin (sim.geo.GeoOrigin), its altitude by frame as PX4 computes it; velocity and acceleration taken as NED.
SET_ATTITUDE_TARGET: an attitude (its quaternion, normalised), or body rates (the attitude ignored,
roll and pitch rates given), and a collective thrust, flown without the position controller.
Pure: it never sees a socket or a clock. Whether OFFBOARD flies it is the commander's rule.
"""

import math

from offboard_py import frames
from offboard_py.dialect import mavlink
from offboard_py.sim import vehicle as vm
from offboard_py.sim.flight_math import rotate_by_yaw

_AXIS_IGNORE_BITS = (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE,
                     mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)
_ACCELERATION_IGNORED = (mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE
                         | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)
SUPPORTED_FRAMES = (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_NED)


class SetpointRejected(ValueError):
    """A SET_POSITION_TARGET_LOCAL_NED that PX4 would not take; the message says why."""


def offboard_setpoint(frame, type_mask, position, velocity, acceleration, yaw, yaw_rate, vehicle_yaw):
    """Decode the fields of a SET_POSITION_TARGET_LOCAL_NED into a vehicle Setpoint. Raises SetpointRejected."""
    if frame not in SUPPORTED_FRAMES:
        raise SetpointRejected('coordinate frame %d is not supported (MAV_FRAME_LOCAL_NED %d or MAV_FRAME_BODY_NED %d)'
                               % (frame, mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_NED))
    if type_mask & mavlink.POSITION_TARGET_TYPEMASK_FORCE_SET and \
            type_mask & _ACCELERATION_IGNORED != _ACCELERATION_IGNORED:
        raise SetpointRejected('force setpoints (POSITION_TARGET_TYPEMASK_FORCE_SET with an acceleration) '
                               'are not supported')
    values = list(position) + list(velocity) + list(acceleration) + [yaw, yaw_rate]
    if any(math.isinf(v) for v in values):
        raise SetpointRejected('infinite value in setpoint')
    nan = vm.NAN
    used = [float(v) if not type_mask & bit else nan for bit, v in zip(_AXIS_IGNORE_BITS, values)]
    if frame == mavlink.MAV_FRAME_BODY_NED:
        used[0:3] = [nan, nan, nan]
        for k in (3, 6):
            if not all(v == v for v in used[k:k + 3]):
                used[k:k + 3] = [nan, nan, nan]  # PX4: one axis ignored drops the vector
            else:
                used[k], used[k + 1] = rotate_by_yaw(used[k], used[k + 1], vehicle_yaw)
    if not any(v == v for v in used):
        raise SetpointRejected('no position, velocity or acceleration in setpoint (type_mask 0x%x)' % type_mask)
    yaw_sp = float(yaw) if not type_mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE and yaw == yaw else nan
    rate_sp = (float(yaw_rate) if not type_mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
               and yaw_rate == yaw_rate else nan)
    return vm.setpoint(position=used[0:3], velocity=used[3:6], acceleration=used[6:9], yaw=yaw_sp, yaw_rate=rate_sp)


def from_message(msg, vehicle_yaw):
    """offboard_setpoint() of a pymavlink SET_POSITION_TARGET_LOCAL_NED."""
    return offboard_setpoint(msg.coordinate_frame, msg.type_mask, (msg.x, msg.y, msg.z), (msg.vx, msg.vy, msg.vz),
                             (msg.afx, msg.afy, msg.afz), msg.yaw, msg.yaw_rate, vehicle_yaw)


# SET_POSITION_TARGET_GLOBAL_INT's frames, as PX4's receiver takes them
GLOBAL_FRAMES = (mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
# ATTITUDE_TARGET_TYPEMASK_THRUST_BODY_SET (32): newer than the dialect this project generates
ATTITUDE_TARGET_TYPEMASK_THRUST_BODY_SET = getattr(mavlink, 'ATTITUDE_TARGET_TYPEMASK_THRUST_BODY_SET', 32)
_POSITION_IGNORED = (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE
                     | mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE)


def global_setpoint(frame, type_mask, lat_int, lon_int, alt, velocity, acceleration, yaw, yaw_rate, origin,
                    home_amsl):
    """Decode a SET_POSITION_TARGET_GLOBAL_INT into a vehicle Setpoint (local NED). `origin` is the
    estimator's origin (sim.geo.GeoOrigin), `home_amsl` home's altitude (m AMSL), None while either is
    not known, when PX4 drops a message with a position. Raises SetpointRejected.

    As PX4's receiver: the position is used only with none of its axes ignored; the altitude is
    the origin's minus `alt` (GLOBAL_INT, AMSL) or home's minus `alt` minus the origin's
    (GLOBAL_RELATIVE_ALT_INT: PX4's own arithmetic, which is -alt when home is at the origin's
    height); GLOBAL_TERRAIN_ALT_INT needs a terrain estimate, which this vehicle has not."""
    if type_mask & _POSITION_IGNORED:
        position = (vm.NAN, vm.NAN, vm.NAN)
    elif frame not in GLOBAL_FRAMES:
        raise SetpointRejected('coordinate frame %d is not supported (MAV_FRAME_GLOBAL_INT %d or '
                               'MAV_FRAME_GLOBAL_RELATIVE_ALT_INT %d)'
                               % (frame, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT))
    elif origin is None or home_amsl is None:
        raise SetpointRejected('no global position yet: a global setpoint needs the estimator\'s origin and home')
    elif not math.isfinite(alt):
        raise SetpointRejected('altitude %r is not a number' % alt)
    else:
        north, east, _ = origin.to_local(lat_int / 1e7, lon_int / 1e7, origin.alt0)
        if frame == mavlink.MAV_FRAME_GLOBAL_INT:
            down = origin.alt0 - alt
        else:
            down = (home_amsl - alt) - origin.alt0
        position = (north, east, down)
    # the rest is read as a LOCAL_NED setpoint's, with the position in place
    if position[0] != position[0]:
        type_mask |= _POSITION_IGNORED
        position = (0.0, 0.0, 0.0)
    return offboard_setpoint(mavlink.MAV_FRAME_LOCAL_NED, type_mask, position, velocity, acceleration, yaw, yaw_rate,
                             0.0)


def from_global_message(msg, origin, home_amsl):
    """global_setpoint() of a pymavlink SET_POSITION_TARGET_GLOBAL_INT."""
    return global_setpoint(msg.coordinate_frame, msg.type_mask, msg.lat_int, msg.lon_int, msg.alt,
                           (msg.vx, msg.vy, msg.vz), (msg.afx, msg.afy, msg.afz), msg.yaw, msg.yaw_rate,
                           origin, home_amsl)


def attitude_setpoint(type_mask, q_wxyz, thrust, body_rates=(0.0, 0.0, 0.0)):
    """Decode a SET_ATTITUDE_TARGET into a vehicle Setpoint, as PX4's receiver reads it: with the
    attitude, fly attitude `q_wxyz` (NED/FRD, normalised here); without it but with roll and pitch
    rates, fly `body_rates` (FRD, rad/s; the yaw rate 0 when ignored); either at collective `thrust`
    (0..1, PX4's fill_thrust for a multicopter; 0 when ignored). Raises SetpointRejected for a message
    with neither (no offboard signal on PX4 either), thrust_body (not modelled), a quaternion that is
    not a rotation, rates or a thrust that are not numbers, or a thrust outside 0..1."""
    if type_mask & ATTITUDE_TARGET_TYPEMASK_THRUST_BODY_SET:
        raise SetpointRejected('thrust_body setpoints (ATTITUDE_TARGET_TYPEMASK_THRUST_BODY_SET) are not modelled')
    if type_mask & mavlink.ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE:
        thrust = 0.0  # PX4 leaves the thrust setpoint at zero: the vehicle falls or stays down
    elif not (math.isfinite(thrust) and 0.0 <= thrust <= 1.0):
        raise SetpointRejected('thrust %r is outside 0..1' % thrust)
    if type_mask & mavlink.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE:
        if type_mask & (mavlink.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE
                        | mavlink.ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE):
            raise SetpointRejected('neither an attitude nor roll and pitch rates (type_mask 0x%x)' % type_mask)
        rates = list(body_rates)
        if type_mask & mavlink.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE:
            rates[2] = 0.0
        if not all(math.isfinite(r) for r in rates):
            raise SetpointRejected('body rates %r are not finite' % (tuple(rates),))
        return vm.setpoint(rates=tuple(float(r) for r in rates), thrust=float(thrust))
    if not all(math.isfinite(c) for c in q_wxyz):
        raise SetpointRejected('attitude quaternion %r is not finite' % (tuple(q_wxyz),))
    norm = math.sqrt(sum(c * c for c in q_wxyz))
    if norm < 1e-6:
        raise SetpointRejected('attitude quaternion is all zero: not a rotation')
    q = tuple(c / norm for c in q_wxyz)
    return vm.setpoint(yaw=frames.quaternion_yaw(frames.wxyz_to_xyzw(*q)), attitude=q, thrust=float(thrust))


def from_attitude_message(msg):
    """attitude_setpoint() of a pymavlink SET_ATTITUDE_TARGET (q is w, x, y, z)."""
    return attitude_setpoint(msg.type_mask, tuple(msg.q), msg.thrust,
                             (msg.body_roll_rate, msg.body_pitch_rate, msg.body_yaw_rate))
