"""mavros global_position: the global position, the raw GPS, and the local position they give.

- ~global_position/global (NavSatFix) from GLOBAL_POSITION_INT, its fix status and covariance
  from the latest GPS_RAW_INT (status -1, no fix, until one arrives, as mavros);
- ~global_position/local (nav_msgs/Odometry, frame map, child base_link): ENU position from
  the map origin (the first position with a fix, through ECEF, as mavros), the vehicle's
  orientation and its ENU velocity;
- ~global_position/rel_alt (Float64, m above home) and ~global_position/compass_hdg (Float64,
  deg, when the FCU gives a heading);
- ~global_position/raw/fix (NavSatFix), raw/gps_vel (TwistStamped, ENU) and raw/satellites
  (UInt32) from GPS_RAW_INT.
Altitudes are AMSL as PX4 sends them: real mavros converts to height above the WGS-84
ellipsoid with a geoid model (EGM96), which this bridge does not carry (see README).
"""

import math

from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import NavSatFix, NavSatStatus
from std_msgs.msg import Float64, UInt32

from offboard_py import frames

UINT16_UNKNOWN = 0xFFFF
FIX_2D = 2  # GPS_FIX_TYPE_2D_FIX: from here on a fix


def _fix_status(fix_type):
    return NavSatStatus.STATUS_FIX if fix_type is not None and fix_type >= FIX_2D else NavSatStatus.STATUS_NO_FIX


def _fill_fix(fix, lat_e7, lon_e7, alt_mm, fix_type, eph_cm, epv_cm):
    fix.status.status, fix.status.service = _fix_status(fix_type), NavSatStatus.SERVICE_GPS
    fix.latitude, fix.longitude, fix.altitude = lat_e7 * 1e-7, lon_e7 * 1e-7, alt_mm * 1e-3
    if eph_cm is not None and eph_cm != UINT16_UNKNOWN:
        # as mavros (after nmea_navsat_driver): HDOP-based, the vertical twice the horizontal
        hdop = eph_cm * 1e-2
        fix.position_covariance[0] = fix.position_covariance[4] = hdop ** 2
        fix.position_covariance[8] = (2.0 * hdop) ** 2
        fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_APPROXIMATED
    else:
        fix.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN


class GlobalPosition:
    def __init__(self, bridge):
        self.bridge = bridge
        self.frame_id = bridge.cfg['global_position/frame_id']
        self.child_frame_id = 'base_link'
        self.gps = None        # the latest GPS_RAW_INT
        self.origin = None     # (lat, lon, ECEF) of the map origin
        self.pub = bridge.publisher('~global_position/global', NavSatFix)
        self.local_pub = bridge.publisher('~global_position/local', Odometry)
        self.rel_alt_pub = bridge.publisher('~global_position/rel_alt', Float64)
        self.hdg_pub = bridge.publisher('~global_position/compass_hdg', Float64)
        self.raw_fix_pub = bridge.publisher('~global_position/raw/fix', NavSatFix)
        self.raw_vel_pub = bridge.publisher('~global_position/raw/gps_vel', TwistStamped)
        self.raw_sat_pub = bridge.publisher('~global_position/raw/satellites', UInt32)
        listened = bridge.listened(self.pub, self.local_pub, self.rel_alt_pub, self.hdg_pub)
        # until the map origin is known every GLOBAL_POSITION_INT is read; then only for a subscriber
        bridge.on('GLOBAL_POSITION_INT', self._on_global_position,
                  needed=lambda: self.origin is None or listened())
        bridge.on('GPS_RAW_INT', self._on_gps_raw)  # the fix status the other topics and diagnostics give
        bridge.diagnostic('GPS', self._gps_status)

    def _gps_status(self):
        """As mavros's GPS diagnostics: no fix is an error ("No satellites"), 2D a warning."""
        gps = self.gps
        if gps is None:
            return 2, 'No satellites', [('Satellites visible', 0), ('Fix type', 0)]
        values = [('Satellites visible', gps.satellites_visible), ('Fix type', gps.fix_type),
                  ('EPH (m)', 'Unknown' if gps.eph == UINT16_UNKNOWN else '%.2f' % (gps.eph * 1e-2)),
                  ('EPV (m)', 'Unknown' if gps.epv == UINT16_UNKNOWN else '%.2f' % (gps.epv * 1e-2))]
        if gps.fix_type < FIX_2D:
            return 2, 'No satellites', values
        if gps.fix_type == FIX_2D:
            return 1, '2D fix', values
        return 0, '3D fix', values

    def _on_gps_raw(self, gps):
        self.gps = gps
        stamp = self.bridge.fcu_stamp_us(gps.time_usec)
        if self.raw_fix_pub.get_num_connections():
            fix = NavSatFix()
            fix.header.stamp, fix.header.frame_id = stamp, self.frame_id
            _fill_fix(fix, gps.lat, gps.lon, gps.alt, gps.fix_type, gps.eph, gps.epv)
            self.raw_fix_pub.publish(fix)
        if gps.vel != UINT16_UNKNOWN and gps.cog != UINT16_UNKNOWN and self.raw_vel_pub.get_num_connections():
            speed, course = gps.vel * 1e-2, math.radians(gps.cog * 1e-2)
            vel = TwistStamped()
            vel.header.stamp, vel.header.frame_id = stamp, self.frame_id
            vel.twist.linear.x, vel.twist.linear.y = speed * math.sin(course), speed * math.cos(course)
            self.raw_vel_pub.publish(vel)
        if gps.satellites_visible != 255 and self.raw_sat_pub.get_num_connections():
            self.raw_sat_pub.publish(UInt32(data=gps.satellites_visible))

    def _on_global_position(self, gp):
        b = self.bridge
        stamp = b.fcu_stamp_ms(gp.time_boot_ms)
        fix_type = self.gps.fix_type if self.gps is not None else None
        if self.pub.get_num_connections():  # nobody listens: skip the work (the topic is not latched)
            fix = NavSatFix()
            fix.header.stamp, fix.header.frame_id = stamp, self.frame_id
            _fill_fix(fix, gp.lat, gp.lon, gp.alt, fix_type, self.gps.eph if self.gps else None,
                      self.gps.epv if self.gps else None)
            self.pub.publish(fix)
        lat, lon, alt = gp.lat * 1e-7, gp.lon * 1e-7, gp.alt * 1e-3
        if self.origin is None and _fix_status(fix_type) == NavSatStatus.STATUS_FIX:
            self.origin = (lat, lon, frames.geodetic_to_ecef(lat, lon, alt))
            b.needs_changed()  # GLOBAL_POSITION_INT is now read only for its subscribers
        if self.origin is not None and self.local_pub.get_num_connections():
            here = frames.geodetic_to_ecef(lat, lon, alt)
            odom = Odometry()
            odom.header.stamp, odom.header.frame_id, odom.child_frame_id = stamp, self.frame_id, self.child_frame_id
            p = odom.pose.pose.position
            p.x, p.y, p.z = frames.ecef_offset_to_enu([h - o for h, o in zip(here, self.origin[2])], *self.origin[:2])
            q = odom.pose.pose.orientation
            q.x, q.y, q.z, q.w = b.attitude.orientation_enu
            v = odom.twist.twist.linear
            v.x, v.y, v.z = frames.ned_to_enu(gp.vx * 1e-2, gp.vy * 1e-2, gp.vz * 1e-2)
            self.local_pub.publish(odom)
        if self.rel_alt_pub.get_num_connections():
            self.rel_alt_pub.publish(Float64(data=gp.relative_alt * 1e-3))
        if gp.hdg != UINT16_UNKNOWN and self.hdg_pub.get_num_connections():
            self.hdg_pub.publish(Float64(data=gp.hdg * 1e-2))
