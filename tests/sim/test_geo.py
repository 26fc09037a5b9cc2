"""The simulator's tracks on the core's tangent plane (`edged.geo.LocalPlane.to_geodetic_array`)."""

from __future__ import annotations

import numpy as np
import pytest

from edged.geo import LocalPlane


def test_a_track_is_the_scalar_mapping_point_by_point():
    plane = LocalPlane(57.6, 11.5)
    north, east = np.linspace(-20_000.0, 20_000.0, 101), np.linspace(15_000.0, -15_000.0, 101)
    lat, lon = plane.to_geodetic_array(north, east)
    for k in range(0, 101, 10):
        assert (lat[k], lon[k]) == pytest.approx(plane.to_geodetic(north[k], east[k]), abs=1e-12)


def test_a_track_across_the_antimeridian_stays_in_range():
    plane = LocalPlane(-40.0, 179.99)
    lat, lon = plane.to_geodetic_array(np.zeros(3), np.array([-2_000.0, 0.0, 2_000.0]))
    assert 179.9 < lon[0] < 179.99
    assert lon[1] == 179.99
    assert -180.0 <= lon[2] < -179.9  # past 180° east: the other side, as `to_geodetic` says
    assert lon[2] == pytest.approx(plane.to_geodetic(0.0, 2_000.0)[1], abs=1e-9)
