"""The real-log harness's own arithmetic (tests/bench/real_logs.py), on a made-up
track: a prediction is judged against the fixes interpolated to its due time, beside
dead reckoning from the last fix at the last SOG/COG, and the 2σ ellipse is read with
its major axis from north clockwise. Fast and deterministic; no log needed."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.append(str(Path(__file__).resolve().parent))  # after tests/support: its manoeuvre_real, not the bench script

import manoeuvre_real  # noqa: E402,F401  (tests/support, on the pytest path)
from real_logs import predictions  # noqa: E402

from edged.geo import LocalPlane  # noqa: E402

PLANE = LocalPlane(57.0, 11.0)


def _track(speed: float = 5.0, heading: float = math.radians(30.0)) -> tuple[np.ndarray, ...]:
    t = np.arange(0.0, 200.0, 1.0)
    ll = [PLANE.to_geodetic(speed * s * math.cos(heading), speed * s * math.sin(heading)) for s in t]
    return t, np.array([a for a, _ in ll]), np.array([b for _, b in ll])


def _estimate(t: float, north: float, east: float, major: float, minor: float, angle: float) -> dict:
    lat, lon = PLANE.to_geodetic(north, east)
    return {"t": t, "stale": False, "predicted": [{"dt": 10.0, "lat": lat, "lon": lon, "std_major": major,
                                                   "std_minor": minor, "std_angle": angle}]}


def test_a_prediction_on_the_track_beats_dead_reckoning_from_a_stale_velocity() -> None:
    fixes = _track()
    # SOG/COG that says 4 m/s at 0°: dead reckoning is off, the prediction is on the track.
    vel = (np.array([0.0]), np.array([4.0]), np.array([0.0]))
    h = math.radians(30.0)
    est = [_estimate(t, 5.0 * (t + 10) * math.cos(h), 5.0 * (t + 10) * math.sin(h), 1.0, 1.0, 0.0)
           for t in (50.5, 80.5, 120.5)]
    got = predictions(est, fixes, vel, PLANE)[10.0]
    assert got["n"] == 3 and got["rms"] < 0.01 and got["in_2sigma"] == 1.0
    # DR: from the fix at t (0.5 s old) at 4 m/s north for 10.5 s against 5 m/s at 30°.
    want = math.hypot(4.0 * 10.5 - 5.0 * 10.5 * math.cos(h), 5.0 * 10.5 * math.sin(h))
    assert got["dr"] == pytest.approx(want, rel=1e-3) and got["ratio"] < 1e-3


def test_the_ellipse_major_axis_is_measured_from_north_clockwise() -> None:
    """An error of 15 m due east of the due position: inside a 2σ ellipse whose major
    axis (σ 10 m) points east (90°), outside one whose major axis points north."""
    fixes = _track(speed=0.0)
    est_east = [_estimate(50.0, 0.0, 15.0, 10.0, 1.0, math.pi / 2)]
    est_north = [_estimate(50.0, 0.0, 15.0, 10.0, 1.0, 0.0)]
    assert predictions(est_east, fixes, None, PLANE)[10.0]["in_2sigma"] == 1.0
    assert predictions(est_north, fixes, None, PLANE)[10.0]["in_2sigma"] == 0.0


def test_rows_not_made_at_their_horizon_and_due_times_without_fixes_are_left_out() -> None:
    fixes = _track()
    carried = {"t": 50.0, "stale": False, "predicted": [{"dt": 9.6, "lat": 57.0, "lon": 11.0}]}
    late = _estimate(195.0, 0.0, 0.0, 1.0, 1.0, 0.0)  # due at 205 s, after the last fix
    stale = dict(_estimate(50.0, 0.0, 0.0, 1.0, 1.0, 0.0), stale=True)
    assert predictions([carried, late, stale], fixes, None, PLANE) == {}
