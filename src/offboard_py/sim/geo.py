"""Local NED <-> WGS 84 around the simulated vehicle's origin (its home at boot).

An equirectangular projection: exact enough within a few kilometres of the origin,
which is where a simulated flight stays. Altitudes are AMSL (m).
"""

import math

EARTH_RADIUS_M = 6371000.0


class GeoOrigin:
    """The estimator's origin: the WGS 84 point (degrees, m AMSL) at local NED (0, 0, 0), and the conversions."""

    def __init__(self, lat_deg, lon_deg, alt_m):
        self.lat0, self.lon0, self.alt0 = lat_deg, lon_deg, alt_m
        self._m_per_deg_lat = math.radians(1.0) * EARTH_RADIUS_M
        self._m_per_deg_lon = self._m_per_deg_lat * math.cos(math.radians(lat_deg))

    def to_local(self, lat_deg, lon_deg, alt_m):
        return ((lat_deg - self.lat0) * self._m_per_deg_lat,
                (lon_deg - self.lon0) * self._m_per_deg_lon,
                self.alt0 - alt_m)

    def to_global(self, north_m, east_m, down_m):
        return (self.lat0 + north_m / self._m_per_deg_lat,
                self.lon0 + east_m / self._m_per_deg_lon,
                self.alt0 - down_m)
