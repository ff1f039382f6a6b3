"""mavros setpoint_position and setpoint_raw: ROS setpoints out as SET_POSITION_TARGET_LOCAL_NED.

- ~setpoint_position/local (PoseStamped, ENU): frame LOCAL_NED, type_mask position and yaw
  (0x9F8), position ENU->NED, yaw from the orientation converted to NED/FRD, after taking from
  it the rotation mavros's Eigen takes (frames.pose_rotation: the all-zero quaternion is the
  identity, facing east). frame_id is ignored, as in mavros.
- ~setpoint_raw/local (PositionTarget): LOCAL_NED (and LOCAL_OFFSET_NED) vectors ENU->NED and
  yaw_ned = pi/2 - yaw; BODY_NED (and BODY_OFFSET_NED) vectors FLU->FRD and yaw negated (mavros
  turns the yaw's quaternion by 180 deg about x: transform_orientation_absolute_frame_aircraft_baselink);
  yaw_rate negated in both; type_mask passed through.
- ~setpoint_velocity/cmd_vel (TwistStamped) and cmd_vel_unstamped (Twist), ENU: frame
  LOCAL_NED, type_mask velocity and yaw rate (0x5C7), as mavros's setpoint_velocity.
- ~setpoint_raw/target_local (PositionTarget, ENU) from POSITION_TARGET_LOCAL_NED: what the
  FCU's controller tracks; ~setpoint_raw/target_attitude (AttitudeTarget) from ATTITUDE_TARGET.
- ~setpoint_raw/attitude (AttitudeTarget, ENU/FLU) out as SET_ATTITUDE_TARGET (orientation to
  NED/FRD as it is, unnormalised or all zero, as mavros's ftf::to_eigen takes it; body rates
  FLU->FRD; thrust times ~setpoint_raw/thrust_scaling (px4_config's 1.0) clamped to 0..1, as
  mavros; with a negative scaling, mavros's "unset", a setpoint with thrust is not sent);
  ~setpoint_raw/global (GlobalPositionTarget) out as SET_POSITION_TARGET_GLOBAL_INT
  (lat/lon *1e7, vectors ENU->NED, yaw and yaw rate to NED).
- ~setpoint_position/global (geographic_msgs/GeoPoseStamped) out as SET_POSITION_TARGET_GLOBAL_INT
  as mavros's setpoint_position sends it: frame GLOBAL_INT (altitude AMSL), type_mask position, yaw
  and yaw rate (0x1F8, yaw rate 0), lat/lon as int32_t(deg * 1e7) (truncated toward zero), the yaw of
  the orientation turned to NED/FRD as it is (not normalised: all zero is yaw 0, north).
- ~setpoint_raw/target_global (GlobalPositionTarget) from POSITION_TARGET_GLOBAL_INT, as mavros
  (velocities NED->ENU, yaw pi/2 - yaw, yaw rate negated). PX4 does not stream it: a silent topic
  there, as with mavros.
A setpoint with a NaN or infinite number in a field it uses is not sent, and is logged
(at most a line per topic every 5 s); in a field its type_mask ignores, it is sent as 0.
"""

import math

import rospy
from geographic_msgs.msg import GeoPoseStamped
from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
from mavros_msgs.msg import AttitudeTarget, GlobalPositionTarget, PositionTarget

from offboard_py import frames
from offboard_py.bridge import c_casts, typemask
from offboard_py.dialect import mavlink

BODY_FRAMES = (PositionTarget.FRAME_BODY_NED, PositionTarget.FRAME_BODY_OFFSET_NED)


def _time_boot_ms(stamp):
    return (stamp.to_nsec() // 1000000) & 0xFFFFFFFF


def _finite(*values):
    return all(math.isfinite(v) for v in values)


def _zero_unfinite(vector):
    """The vector with NaN/inf components (in fields the type_mask ignores) as 0."""
    return type(vector)(*(c if math.isfinite(c) else 0.0 for c in (vector.x, vector.y, vector.z)))


class Setpoint:
    def __init__(self, bridge):
        self.bridge = bridge
        self.rejected = 0
        self._last_log_s = {}
        self.subs = [
            bridge.subscriber('~setpoint_position/local', PoseStamped, self._on_pose),
            bridge.subscriber('~setpoint_raw/local', PositionTarget, self._on_raw),
            bridge.subscriber('~setpoint_velocity/cmd_vel', TwistStamped,
                              lambda msg: self._on_velocity('setpoint_velocity/cmd_vel', msg.header.stamp, msg.twist)),
            bridge.subscriber('~setpoint_velocity/cmd_vel_unstamped', Twist,
                              lambda msg: self._on_velocity('setpoint_velocity/cmd_vel_unstamped', bridge.now(), msg)),
        ]
        self.subs += [bridge.subscriber('~setpoint_raw/attitude', AttitudeTarget, self._on_raw_attitude),
                      bridge.subscriber('~setpoint_raw/global', GlobalPositionTarget, self._on_raw_global),
                      bridge.subscriber('~setpoint_position/global', GeoPoseStamped, self._on_geo_pose)]
        self.target_pub = bridge.publisher('~setpoint_raw/target_local', PositionTarget)
        self.target_attitude_pub = bridge.publisher('~setpoint_raw/target_attitude', AttitudeTarget)
        bridge.on('POSITION_TARGET_LOCAL_NED', self._on_target, needed=bridge.listened(self.target_pub))
        bridge.on('ATTITUDE_TARGET', self._on_target_attitude, needed=bridge.listened(self.target_attitude_pub))
        self.target_global_pub = bridge.publisher('~setpoint_raw/target_global', GlobalPositionTarget)
        bridge.on('POSITION_TARGET_GLOBAL_INT', self._on_target_global, needed=bridge.listened(self.target_global_pub))

    def reject(self, topic, what):
        """Count and log; at most one line per topic every 5 s (rospy's throttle would merge topics)."""
        self.rejected += 1
        now = self.bridge.monotonic_s()
        if now - self._last_log_s.get(topic, -math.inf) >= 5.0:
            self._last_log_s[topic] = now
            rospy.logwarn('SP: %s: setpoint with %s not sent (%d rejected so far)', topic, what, self.rejected)

    def _on_pose(self, msg):
        p, q = msg.pose.position, msg.pose.orientation
        if not _finite(p.x, p.y, p.z, q.x, q.y, q.z, q.w):
            self.reject('setpoint_position/local', 'a NaN or infinite value')
            return
        north, east, down = frames.enu_to_ned(p.x, p.y, p.z)
        yaw = frames.quaternion_yaw(frames.orientation_enu_to_ned(frames.pose_rotation((q.x, q.y, q.z, q.w))))
        b = self.bridge
        b.send(b.mav.set_position_target_local_ned_encode(
            _time_boot_ms(msg.header.stamp), b.target_system, b.target_component, mavlink.MAV_FRAME_LOCAL_NED,
            typemask.POSITION_YAW, north, east, down, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, yaw, 0.0))

    def _on_raw(self, msg):
        p, v, a = msg.position, msg.velocity, msg.acceleration_or_force
        bad = typemask.bad_used_fields(msg.type_mask, typemask.position_target_values(msg))
        if bad:
            self.reject('setpoint_raw/local', 'a NaN or infinite %s' % ', '.join(bad))
            return
        # PX4 ignores what the mask ignores; send zeros there rather than NaN
        p, v, a = (_zero_unfinite(c) for c in (p, v, a))
        body = msg.coordinate_frame in BODY_FRAMES
        convert = frames.flu_to_frd if body else frames.enu_to_ned
        position, velocity, accel = (convert(c.x, c.y, c.z) for c in (p, v, a))
        yaw_to_ned = frames.yaw_flu_to_frd if body else frames.yaw_enu_to_ned
        yaw = yaw_to_ned(msg.yaw) if math.isfinite(msg.yaw) else 0.0
        yaw_rate = -msg.yaw_rate if math.isfinite(msg.yaw_rate) else 0.0
        b = self.bridge
        b.send(b.mav.set_position_target_local_ned_encode(
            _time_boot_ms(msg.header.stamp), b.target_system, b.target_component, msg.coordinate_frame,
            msg.type_mask, *position, *velocity, *accel, yaw, yaw_rate))

    def _on_velocity(self, topic, stamp, twist):
        v, w = twist.linear, twist.angular
        if not _finite(v.x, v.y, v.z, w.z):
            self.reject(topic, 'a NaN or infinite value')
            return
        b = self.bridge
        b.send(b.mav.set_position_target_local_ned_encode(
            _time_boot_ms(stamp), b.target_system, b.target_component, mavlink.MAV_FRAME_LOCAL_NED,
            typemask.VELOCITY_YAW_RATE, 0.0, 0.0, 0.0, *frames.enu_to_ned(v.x, v.y, v.z), 0.0, 0.0, 0.0,
            0.0, -w.z))

    def _on_target(self, tgt):
        msg = PositionTarget()
        msg.header.stamp = self.bridge.fcu_stamp_ms(tgt.time_boot_ms)
        msg.coordinate_frame, msg.type_mask = tgt.coordinate_frame, tgt.type_mask
        for field, vector in ((msg.position, (tgt.x, tgt.y, tgt.z)), (msg.velocity, (tgt.vx, tgt.vy, tgt.vz)),
                              (msg.acceleration_or_force, (tgt.afx, tgt.afy, tgt.afz))):
            field.x, field.y, field.z = frames.ned_to_enu(*vector)
        msg.yaw = frames.yaw_ned_to_enu(tgt.yaw) if math.isfinite(tgt.yaw) else tgt.yaw
        msg.yaw_rate = -tgt.yaw_rate
        self.target_pub.publish(msg)

    def send_attitude_target(self, topic, stamp, type_mask, q, rates, thrust):
        """SET_ATTITUDE_TARGET from an ENU/FLU orientation (x, y, z, w) and FLU body rates."""
        used = [] if type_mask & AttitudeTarget.IGNORE_ATTITUDE else list(q)
        used += [] if type_mask & AttitudeTarget.IGNORE_THRUST else [thrust]
        used += [r for r, bit in zip(rates, (AttitudeTarget.IGNORE_ROLL_RATE, AttitudeTarget.IGNORE_PITCH_RATE,
                                              AttitudeTarget.IGNORE_YAW_RATE)) if not type_mask & bit]
        if not _finite(*used):
            self.reject(topic, 'a NaN or infinite value')
            return
        q_ned = frames.orientation_enu_to_ned(q if _finite(*q) else (0.0, 0.0, 0.0, 0.0))
        rates = frames.flu_to_frd(*(r if math.isfinite(r) else 0.0 for r in rates))
        self.send_attitude_target_ned(topic, stamp, type_mask, q_ned, rates, thrust if math.isfinite(thrust) else 0.0)

    def send_attitude_target_ned(self, topic, stamp, type_mask, q_ned, rates, thrust):
        """SET_ATTITUDE_TARGET of an orientation (x, y, z, w) and body rates already in the FCU's frames."""
        if not _finite(*rates, thrust):
            self.reject(topic, 'a NaN or infinite value')
            return
        b = self.bridge
        b.send(b.mav.set_attitude_target_encode(
            _time_boot_ms(stamp), b.target_system, b.target_component, type_mask,
            [q_ned[3], q_ned[0], q_ned[1], q_ned[2]], *rates, thrust))

    def _on_raw_attitude(self, msg):
        q, w = msg.orientation, msg.body_rate
        scaling = self.bridge.cfg['setpoint_raw/thrust_scaling']
        if scaling < 0.0 and msg.thrust != 0.0:
            self.reject('setpoint_raw/attitude', 'thrust while ~setpoint_raw/thrust_scaling is negative (unset)')
            return
        thrust = msg.thrust * scaling
        thrust = min(1.0, max(0.0, thrust)) if math.isfinite(thrust) else thrust
        self.send_attitude_target('setpoint_raw/attitude', msg.header.stamp, msg.type_mask, (q.x, q.y, q.z, q.w),
                                  (w.x, w.y, w.z), thrust)

    def _on_raw_global(self, msg):
        values = {'position.x': msg.latitude, 'position.y': msg.longitude, 'position.z': msg.altitude,
                  'velocity.x': msg.velocity.x, 'velocity.y': msg.velocity.y, 'velocity.z': msg.velocity.z,
                  'acceleration_or_force.x': msg.acceleration_or_force.x,
                  'acceleration_or_force.y': msg.acceleration_or_force.y,
                  'acceleration_or_force.z': msg.acceleration_or_force.z, 'yaw': msg.yaw, 'yaw_rate': msg.yaw_rate}
        bad = typemask.bad_used_fields(msg.type_mask, values)
        if bad:
            self.reject('setpoint_raw/global', 'a NaN or infinite %s' % ', '.join(bad))
            return
        if not (-90.0 <= msg.latitude <= 90.0 and -180.0 <= msg.longitude <= 180.0) and not msg.type_mask & 3:
            self.reject('setpoint_raw/global', 'latitude/longitude out of range')
            return
        v, a = (_zero_unfinite(c) for c in (msg.velocity, msg.acceleration_or_force))
        b = self.bridge
        b.send(b.mav.set_position_target_global_int_encode(
            _time_boot_ms(msg.header.stamp), b.target_system, b.target_component, msg.coordinate_frame,
            msg.type_mask, int(round(msg.latitude * 1e7)) if math.isfinite(msg.latitude) else 0,
            int(round(msg.longitude * 1e7)) if math.isfinite(msg.longitude) else 0,
            msg.altitude if math.isfinite(msg.altitude) else 0.0, *frames.enu_to_ned(v.x, v.y, v.z),
            *frames.enu_to_ned(a.x, a.y, a.z), frames.yaw_enu_to_ned(msg.yaw) if math.isfinite(msg.yaw) else 0.0,
            -msg.yaw_rate if math.isfinite(msg.yaw_rate) else 0.0))

    def _on_geo_pose(self, msg):
        p, q = msg.pose.position, msg.pose.orientation
        if not _finite(p.latitude, p.longitude, p.altitude, q.x, q.y, q.z, q.w):
            self.reject('setpoint_position/global', 'a NaN or infinite value')
            return
        yaw = frames.quaternion_yaw(frames.orientation_enu_to_ned((q.x, q.y, q.z, q.w)))
        b = self.bridge
        b.send(b.mav.set_position_target_global_int_encode(
            _time_boot_ms(msg.header.stamp), b.target_system, b.target_component, mavlink.MAV_FRAME_GLOBAL_INT,
            typemask.POSITION_YAW_YAW_RATE, c_casts.int32_from_double(p.latitude * 1e7),
            c_casts.int32_from_double(p.longitude * 1e7), p.altitude, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, yaw, 0.0))

    def _on_target_global(self, tgt):
        msg = GlobalPositionTarget(coordinate_frame=tgt.coordinate_frame, type_mask=tgt.type_mask,
                                   latitude=tgt.lat_int / 1e7, longitude=tgt.lon_int / 1e7, altitude=tgt.alt)
        msg.header.stamp = self.bridge.fcu_stamp_ms(tgt.time_boot_ms)
        msg.velocity.x, msg.velocity.y, msg.velocity.z = frames.ned_to_enu(tgt.vx, tgt.vy, tgt.vz)
        a = msg.acceleration_or_force
        a.x, a.y, a.z = frames.ned_to_enu(tgt.afx, tgt.afy, tgt.afz)
        msg.yaw = frames.yaw_ned_to_enu(tgt.yaw) if math.isfinite(tgt.yaw) else tgt.yaw
        msg.yaw_rate = -tgt.yaw_rate
        self.target_global_pub.publish(msg)

    def _on_target_attitude(self, tgt):
        msg = AttitudeTarget(type_mask=tgt.type_mask, thrust=tgt.thrust)
        msg.header.stamp = self.bridge.fcu_stamp_ms(tgt.time_boot_ms)
        q = frames.orientation_ned_to_enu(frames.wxyz_to_xyzw(*tgt.q))
        msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w = q
        msg.body_rate.x, msg.body_rate.y, msg.body_rate.z = frames.frd_to_flu(
            tgt.body_roll_rate, tgt.body_pitch_rate, tgt.body_yaw_rate)
        self.target_attitude_pub.publish(msg)
