"""Local tangent plane <-> WGS-84 geodetic, and unit conversions.

The simulated tracks span a few tens of kilometres at most, so a flat plane anchored at
the start position with the ellipsoid's radii of curvature there is exact to well below
GNSS noise; the same mapping is used for the truth and for the sensors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from edged.angles import wrap_2pi, wrap_pi  # noqa: F401 (the simulator's modules use them through here)
from edged.units import KNOT  # noqa: F401 (used through here)

_A = 6378137.0  # WGS-84 semi-major axis
_E2 = 6.69437999014e-3  # WGS-84 first eccentricity squared


@dataclass(frozen=True)
class LocalFrame:
    """North/east metres around an origin (lat0, lon0 in degrees)."""

    lat0: float
    lon0: float

    @property
    def _radii(self) -> tuple[float, float]:
        s = math.sin(math.radians(self.lat0))
        w = 1.0 - _E2 * s * s
        r_meridian = _A * (1.0 - _E2) / w**1.5
        r_normal = _A / math.sqrt(w)
        return r_meridian, r_normal * math.cos(math.radians(self.lat0))

    def to_geodetic(self, north: np.ndarray, east: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rm, rp = self._radii
        return self.lat0 + np.degrees(north / rm), self.lon0 + np.degrees(east / rp)

    def to_local(self, lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rm, rp = self._radii
        return np.radians(lat - self.lat0) * rm, np.radians(lon - self.lon0) * rp


