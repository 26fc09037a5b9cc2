"""A local tangent plane (north, east in metres): the estimators' common geometry, and the simulator's.

Flat-earth coordinates are exact enough within a few kilometres of their origin; a
voyage leaves any fixed origin behind (100 km north at 45° changes the east scale by
1.2 %, i.e. 0.1 m/s of false velocity at 15 kn). So the filter re-anchors the plane at
its own position whenever it has moved `radius` away, shifting the position states by
the same amount: velocities and covariances are untouched.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

A_WGS84 = 6378137.0
#: The mean Earth radius (IUGG), m: `north_east`'s sphere.
EARTH_RADIUS = 6_371_008.8
E2_WGS84 = 6.69437999014e-3


class LocalPlane:
    """North/east metres about (lat0, lon0), with the WGS-84 radii of curvature there."""

    __slots__ = ("lat0", "lon0", "_m", "_n")

    def __init__(self, lat0: float, lon0: float) -> None:
        self.lat0 = lat0
        self.lon0 = lon0
        s = math.sin(math.radians(lat0))
        w = 1.0 - E2_WGS84 * s * s
        self._m = A_WGS84 * (1.0 - E2_WGS84) / w**1.5  # meridian radius
        self._n = A_WGS84 / math.sqrt(w) * math.cos(math.radians(lat0))  # parallel radius

    def to_ne(self, lat: float, lon: float) -> tuple[float, float]:
        dlon = (lon - self.lon0 + 180.0) % 360.0 - 180.0
        return math.radians(lat - self.lat0) * self._m, math.radians(dlon) * self._n

    def to_geodetic(self, north: float, east: float) -> tuple[float, float]:
        lat = self.lat0 + math.degrees(north / self._m)
        lon = self.lon0 + math.degrees(east / self._n) if self._n > 1e-6 else self.lon0
        return lat, (lon + 180.0) % 360.0 - 180.0

    def to_geodetic_array(self, north: np.ndarray, east: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`to_geodetic` of whole tracks (numpy arrays: the simulator's truth and GNSS).

        A longitude is brought back into [−180°, 180°) only when it left it (by 360°
        once), not by `to_geodetic`'s modulo: in range it stays exactly as computed,
        so the simulator's files are bit for bit what its own copy of this plane wrote
        (issue 33)."""
        import numpy as np  # (here: the estimators' scalar path needs no numpy)

        lat = self.lat0 + np.degrees(north / self._m)
        if self._n <= 1e-6:  # at a pole every east is the origin's meridian
            return lat, np.full_like(east, self.lon0, dtype=float)
        lon = self.lon0 + np.degrees(east / self._n)
        return lat, np.where(lon >= 180.0, lon - 360.0, np.where(lon < -180.0, lon + 360.0, lon))


def north_east(lat: Any, lon: Any, lat0: Any, lon0: Any) -> tuple[np.ndarray, np.ndarray]:
    """North and east metres of (lat, lon) from (lat0, lon0) on the mean sphere,
    degrees in, arrays out (each argument a number or an array); the longitude
    difference taken the short way round, in (−180°, 180°].

    Equirectangular: north = Δlat·R, east = Δlon·R·cos(lat₀). It is not `LocalPlane`
    on purpose: `edged score`'s position errors and `edged plot`'s tracks are measured
    with it, whole arrays at once, and the published scores were made with it; the
    WGS-84 radii of `LocalPlane` give distances up to 0.5 % apart (far below what
    separates two estimators, but the figures would move)."""
    import numpy as np

    dlon = 180.0 - np.mod(180.0 - (np.asarray(lon) - lon0), 360.0)
    north = np.radians(np.asarray(lat) - lat0) * EARTH_RADIUS
    east = np.radians(dlon) * EARTH_RADIUS * np.cos(np.radians(lat0))
    return north, east


def haversine(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """The great-circle distance in metres between two points (degrees) on the mean
    sphere: the distance run between two fixes (the STW paper's distance state)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians(lon2 - lon1)
    h = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2.0 * EARTH_RADIUS * math.asin(min(1.0, math.sqrt(h)))
