"""PX4's geofence in the simulated PX4: the fence a ground station uploads (MISSION_COUNT .. MISSION_ITEM_INT with
mission_type FENCE, as mavros's geofence/push and QGroundControl send it) and the navigator's check of the
vehicle against it and against GF_MAX_HOR_DIST / GF_MAX_VER_DIST from home (PX4 main 02e73e3b6f,
src/modules/navigator/geofence.cpp and navigator_main.cpp geofence_breach_check).

- The fence: polygons (NAV_FENCE_POLYGON_VERTEX_INCLUSION / _EXCLUSION, param1 the vertex count of the
  polygon, one item per vertex) and circles (NAV_FENCE_CIRCLE_INCLUSION / _EXCLUSION, param1 the radius, m),
  in global frames; inside every inclusion and outside every exclusion is inside the fence. An empty fence
  holds everything.
- The check runs every GEOFENCE_CHECK_INTERVAL_S while GF_ACTION is not 0, on the vehicle's position
  (GF_PREDICT 0, PX4 SITL's) and says which of PX4's three breaches hold: 'custom' (the uploaded fence),
  'max_dist' (GF_MAX_HOR_DIST > 0 from home) and 'max_alt' (GF_MAX_VER_DIST > 0 above home). Once a breach
  made the vehicle hold (GF_ACTION 2, AUTO.LOITER), the breaches only accumulate while it loiters.
The commander makes the breaches a failsafe condition (GF_ACTION); what flies then is its business.
Pure: time is passed in.
"""

import math

from offboard_py.dialect import mavlink

GEOFENCE_CHECK_INTERVAL_S = 0.2  # GeofenceBreachAvoidance: GEOFENCE_CHECK_INTERVAL_US
GF_ACTION_LOITER = 2
HOLD_GRACE_S = 0.1  # the hold after a breach ends 100 ms after the vehicle left AUTO.LOITER
EARTH_RADIUS_M = 6371000.0
CIRCLES = (mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION)
POLYGONS = (mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION)
INCLUSIONS = (mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION)


def horizontal_distance_m(lat1, lon1, lat2, lon2):
    """Great-circle distance (m) between two points in degrees."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians(lon2 - lon1)
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(a)))


def inside_polygon(vertices, lat, lon):
    """Geofence::insidePolygon: PNPOLY over (lat, lon) vertices."""
    inside = False
    j = len(vertices) - 1
    for i in range(len(vertices)):
        (lat_i, lon_i), (lat_j, lon_j) = vertices[i], vertices[j]
        if (lon_i >= lon) != (lon_j >= lon) and lat <= (lat_j - lat_i) * (lon - lon_i) / (lon_j - lon_i) + lat_i:
            inside = not inside
        j = i
    return inside


class Geofence:
    """The uploaded fence and the navigator's check against it."""

    def __init__(self, params):
        self.params = params
        self.areas = []   # (command, [(lat, lon), ...] or ((lat, lon), radius_m))
        self.checked_s = None
        self.breaches = frozenset()
        self.holding_since_s = None  # loitering after a breach (navigator's _time_loitering_after_gf_breach)

    def load(self, items):
        """The FENCE list (mission_manager Items, x/y in degrees): its polygons and circles."""
        self.areas = []
        i = 0
        while i < len(items):
            it = items[i]
            if it.command in CIRCLES:
                self.areas.append((it.command, ((it.x, it.y), float(it.param1))))
                i += 1
            elif it.command in POLYGONS:
                count = max(1, int(it.param1))
                self.areas.append((it.command, [(v.x, v.y) for v in items[i:i + count]]))
                i += count
            else:  # a return point: no area
                i += 1

    def holds(self, lat, lon):
        """Geofence::isInsidePolygonOrCircle for a point in degrees."""
        for command, area in self.areas:
            if command in CIRCLES:
                (c_lat, c_lon), radius = area
                inside = horizontal_distance_m(lat, lon, c_lat, c_lon) < radius
            else:
                inside = len(area) >= 3 and inside_polygon(area, lat, lon)
            if inside != (command in INCLUSIONS):
                return False
        return True

    def due(self, now_s):
        """A check is due: GF_ACTION is not 0 and GEOFENCE_CHECK_INTERVAL_S passed since the last."""
        if self.params['GF_ACTION'] == 0:
            self.breaches, self.holding_since_s = frozenset(), None
            return False
        return self.checked_s is None or now_s - self.checked_s >= GEOFENCE_CHECK_INTERVAL_S - 1e-9

    def check(self, now_s, position, home, armed, loitering):
        """The breaches now: `position` and `home` (lat, lon, alt AMSL); `loitering`: in AUTO.LOITER."""
        p = self.params
        self.checked_s = now_s
        if self.holding_since_s is not None and not loitering and now_s - self.holding_since_s > HOLD_GRACE_S:
            self.holding_since_s = None
        lat, lon, alt = position
        found = set()
        if p['GF_MAX_HOR_DIST'] > 0 and horizontal_distance_m(lat, lon, home[0], home[1]) >= p['GF_MAX_HOR_DIST']:
            found.add('max_dist')
        if p['GF_MAX_VER_DIST'] > 0 and alt - home[2] >= p['GF_MAX_VER_DIST']:
            found.add('max_alt')
        if not self.holds(lat, lon):
            found.add('custom')
        if self.holding_since_s is not None:  # holding after a breach: breaches only accumulate
            found |= self.breaches
        elif found and armed and p['GF_ACTION'] == GF_ACTION_LOITER:
            self.holding_since_s = now_s  # the navigator's reposition to hold where the breach was seen
        self.breaches = frozenset(found)
        return self.breaches
