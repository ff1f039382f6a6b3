"""mavros global_position: the global position, the raw GPS, and the local position they give.

- ~global_position/global (NavSatFix, frame ~global_position/child_frame_id, base_link, as mavros
  1.21 stamps it) from GLOBAL_POSITION_INT, its fix status and covariance from the latest GPS_RAW_INT
  (no fix and an unknown covariance until one arrives, as mavros); a fix from a 3D fix on;
- ~global_position/local (nav_msgs/Odometry, frame map, child base_link): ENU position from
  the map origin (the first position with a fix, through ECEF, as mavros), z the height above home
  (~global_position/use_relative_alt, true), the vehicle's orientation, and the velocity as mavros
  1.21 gives it (east, north, and NED's vz unchanged: positive down); the fix's covariance and
  ~global_position/rot_covariance (99999) in the pose's, the twist's unknown;
- ~global_position/rel_alt (Float64, m above home) and ~global_position/compass_hdg (Float64,
  deg, when the FCU gives a heading);
- ~global_position/raw/fix (NavSatFix, base_link; covariance the receiver's h_acc/v_acc when given,
  else EPH/EPV times ~global_position/gps_uere), raw/gps_vel (TwistStamped, ENU, frame map) and
  raw/satellites (UInt32) from GPS_RAW_INT.
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
    """NavSatStatus of a GPS_RAW_INT fix type: a fix from 3D on, as mavros 1.21 reads fix_type > 2."""
    return NavSatStatus.STATUS_FIX if fix_type is not None and fix_type > FIX_2D else NavSatStatus.STATUS_NO_FIX


def _raw_covariance(gps, uere):
    """NavSatFix's position covariance and its type from a GPS_RAW_INT, as mavros 1.21 makes them: the
    receiver's accuracies (h_acc, v_acc, mm) squared when it gives both (MAVLink 2's extension fields),
    else EPH and EPV (cm) times the range error (~global_position/gps_uere) squared, else (and before
    the first GPS_RAW_INT, gps None) unknown."""
    cov = [0.0] * 9
    if gps is not None and gps.h_acc > 0 and gps.v_acc > 0:
        cov[0] = cov[4] = (gps.h_acc * 1e-3) ** 2
        cov[8] = (gps.v_acc * 1e-3) ** 2
        return cov, NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN
    if gps is not None and gps.eph != UINT16_UNKNOWN and gps.epv != UINT16_UNKNOWN:
        cov[0] = cov[4] = (gps.eph * 1e-2 * uere) ** 2
        cov[8] = (gps.epv * 1e-2 * uere) ** 2
        return cov, NavSatFix.COVARIANCE_TYPE_APPROXIMATED
    cov[0] = -1.0
    return cov, NavSatFix.COVARIANCE_TYPE_UNKNOWN


def _fill_fix(fix, lat_e7, lon_e7, alt_mm, gps, uere):
    """A NavSatFix's position, and its status and covariance from the latest GPS_RAW_INT (None: no fix,
    covariance unknown, as mavros before its first GPS_RAW_INT)."""
    fix.status.status, fix.status.service = _fix_status(gps.fix_type if gps else None), NavSatStatus.SERVICE_GPS
    fix.latitude, fix.longitude, fix.altitude = lat_e7 * 1e-7, lon_e7 * 1e-7, alt_mm * 1e-3
    fix.position_covariance, fix.position_covariance_type = _raw_covariance(gps, uere)


class GlobalPosition:
    def __init__(self, bridge):
        self.bridge = bridge
        self.frame_id = bridge.cfg['global_position/frame_id']
        self.child_frame_id = bridge.cfg['global_position/child_frame_id']
        self.uere = bridge.cfg['global_position/gps_uere']
        self.rot_cov = bridge.cfg['global_position/rot_covariance']
        self.use_relative_alt = bridge.cfg['global_position/use_relative_alt']
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
            fix.header.stamp, fix.header.frame_id = stamp, self.child_frame_id  # as mavros 1.21 stamps it
            _fill_fix(fix, gps.lat, gps.lon, gps.alt, gps, self.uere)
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
        # asked once: a subscriber that comes between two asks must not find half the work done
        want_global, want_local = self.pub.get_num_connections(), self.local_pub.get_num_connections()
        fix = None
        if want_global or want_local:  # the topics are not latched: nobody listens, no work
            fix = NavSatFix()
            fix.header.stamp, fix.header.frame_id = stamp, self.child_frame_id
            _fill_fix(fix, gp.lat, gp.lon, gp.alt, self.gps, self.uere)
        if want_global:
            self.pub.publish(fix)
        lat, lon, alt = gp.lat * 1e-7, gp.lon * 1e-7, gp.alt * 1e-3
        if self.origin is None and _fix_status(fix_type) == NavSatStatus.STATUS_FIX:
            self.origin = (lat, lon, frames.geodetic_to_ecef(lat, lon, alt))
            b.needs_changed()  # GLOBAL_POSITION_INT is now read only for its subscribers
        if self.origin is not None and want_local:
            here = frames.geodetic_to_ecef(lat, lon, alt)
            odom = Odometry()
            odom.header.stamp, odom.header.frame_id, odom.child_frame_id = stamp, self.frame_id, self.child_frame_id
            p = odom.pose.pose.position
            p.x, p.y, p.z = frames.ecef_offset_to_enu([h - o for h, o in zip(here, self.origin[2])], *self.origin[:2])
            if self.use_relative_alt:  # mavros's default: the height above home, not above the origin
                p.z = gp.relative_alt * 1e-3
            q = odom.pose.pose.orientation
            q.x, q.y, q.z, q.w = b.attitude.orientation_enu
            # mavros 1.21 swaps north and east but leaves vz as it comes (positive down): so here
            v = odom.twist.twist.linear
            v.x, v.y, v.z = gp.vy * 1e-2, gp.vx * 1e-2, gp.vz * 1e-2
            # the pose's covariance: the fix's in the position block, rot_covariance on the rotation's
            # diagonal; the twist's unknown (element 0 -1), as mavros fills them
            cov = [0.0] * 36
            for row in range(3):
                cov[6 * row:6 * row + 3] = fix.position_covariance[3 * row:3 * row + 3]
            cov[21] = cov[28] = cov[35] = self.rot_cov
            odom.pose.covariance = cov
            odom.twist.covariance = [-1.0] + [0.0] * 35
            self.local_pub.publish(odom)
        if self.rel_alt_pub.get_num_connections():
            self.rel_alt_pub.publish(Float64(data=gp.relative_alt * 1e-3))
        if gp.hdg != UINT16_UNKNOWN and self.hdg_pub.get_num_connections():
            self.hdg_pub.publish(Float64(data=gp.hdg * 1e-2))
