"""Truth is self-consistent: positions are the integral of the velocities and heading,
accelerations the derivatives of the velocities, the accelerometer reading the
accelerations with the Coriolis terms; and the scenarios do what their papers say."""

from __future__ import annotations

import math

import numpy as np
import pytest

from edged.angles import wrap_pi
from edged.units import KNOT
from edged_sim.environment import Water, barrass_squat
from edged_sim.run import Simulation
from edged_sim.scenarios import SCENARIOS


def _truth(name: str, duration: float, seed: int = 1) -> dict[str, np.ndarray]:
    sim = Simulation(SCENARIOS[name], seed=seed, duration=duration)
    chunks = [c.truth for c in sim.chunks(100.0)]
    return {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}


def _trapz_cumulative(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.concatenate(([0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))))


@pytest.mark.parametrize("name", ["manoeuvre-williamson", "stw-cross-current"])
def test_positions_integrate_velocities_and_heading(name: str) -> None:
    tr = _truth(name, 300.0)
    t, psi = tr["t_rel"], np.unwrap(tr["heading"])
    vn = tr["u"] * np.cos(psi) - tr["v"] * np.sin(psi)
    ve = tr["u"] * np.sin(psi) + tr["v"] * np.cos(psi)
    dt = t[1] - t[0]
    # Trapezoid at the truth rate against RK4 at the integration step: metres over 300 s.
    assert np.max(np.abs(_trapz_cumulative(vn, t) - tr["x"])) < 0.05 * dt / 0.1 + 0.02
    assert np.max(np.abs(_trapz_cumulative(ve, t) - tr["y"])) < 0.05 * dt / 0.1 + 0.02
    # sog/cog are the same velocity, and lat/lon the same positions.
    np.testing.assert_allclose(tr["sog"], np.hypot(vn, ve), atol=1e-9)
    assert np.max(np.abs(wrap_pi(tr["cog"] - np.arctan2(ve, vn)))) < 1e-9


@pytest.mark.parametrize("name", ["manoeuvre-williamson", "stw-cross-current"])
def test_accelerations_are_derivatives_of_velocities(name: str) -> None:
    tr = _truth(name, 300.0)
    t = tr["t_rel"]
    for vel, acc in (("u", "a_u"), ("v", "a_v")):
        integrated = tr[vel][0] + _trapz_cumulative(tr[acc], t)
        assert np.max(np.abs(integrated - tr[vel])) < 2e-3, vel
    np.testing.assert_allclose(tr["ax"], tr["a_u"] - tr["v"] * tr["r"], atol=1e-12)
    np.testing.assert_allclose(tr["ay"], tr["a_v"] + tr["u"] * tr["r"], atol=1e-12)
    r_int = tr["heading"][0] + _trapz_cumulative(tr["r"], t)
    assert np.max(np.abs(wrap_pi(r_int - tr["heading"]))) < 1e-3


def test_current_from_astern_is_the_difference_of_sog_and_stw() -> None:
    tr = _truth("stw-astern-current", 200.0)
    np.testing.assert_allclose(tr["current_along"], 1.0, atol=1e-9)
    np.testing.assert_allclose(tr["sog"] - tr["stw"], 1.0, atol=1e-6)
    assert np.all(np.abs(tr["current_cross"]) < 1e-9)


def test_williamson_sequence_fires_in_order_and_crosses_north() -> None:
    sim = Simulation(SCENARIOS["manoeuvre-williamson"], seed=0)
    tr = [c.truth for c in sim.chunks(300.0)]
    heading = np.degrees(np.concatenate([c["heading"] for c in tr]))
    u = np.concatenate([c["u"] for c in tr])
    fired = [i for i, _ in sim.helm.fired]
    assert fired == [0, 1, 2, 3, 4]  # 35° stbd, port at 090, 10° port at 300, midships at 230, slow at 210
    assert heading.min() < 5.0 and heading.max() > 355.0  # the 0/360 switch of seed 002
    loss = 1.0 - u.min() / u[0]
    assert 0.25 < loss < 0.75  # speed lost in the hard-over turns and the slow-down
    times = [t for _, t in sim.helm.fired]
    assert times == sorted(times) and times[0] == 120.0


def test_zigzag_swings_across_north() -> None:
    tr = _truth("manoeuvre-zigzag-north", 600.0)
    dev = np.degrees(wrap_pi(tr["heading"]))
    assert dev.max() > 20.0 and dev.min() < -20.0  # overshoot past ±20°
    assert np.sum(np.diff(np.sign(dev)) != 0) >= 4


def test_squat_scenario_matches_the_paper() -> None:
    """Seed 003 §7.4: 10 kn gives 11.6 m from 10 m, 15 kn 13.6 m (K = 2 at blockage 0.25)."""
    tr = _truth("draft-squat", 300.0)
    t = tr["t_rel"]
    early, late = t < 45.0, t > 280.0
    assert np.all(np.abs(tr["stw"][early] / KNOT - 10.0) < 0.05)
    assert np.all(np.abs(tr["stw"][late] / KNOT - 15.0) < 0.1)
    np.testing.assert_allclose(tr["squat"][early], 1.6, atol=0.03)
    np.testing.assert_allclose(tr["mean_draft"][late], 13.6, atol=0.06)
    assert np.all(tr["ukc"] < 14.0 - 10.0)


def test_barrass_is_zero_in_deep_water_and_uses_width_of_influence_in_open_water() -> None:
    v = np.array([10.0 * KNOT])
    assert barrass_squat(v, np.array([10.0]), 32.2, 0.8, Water(depth=60.0))[0] == 0.0
    open_water = barrass_squat(v, np.array([10.0]), 32.2, 0.8, Water(depth=12.0))[0]
    width = 7.04 * 32.2 / 0.8**0.85
    blockage = 32.2 * 10.0 / (width * 12.0)
    assert blockage < 0.1  # the open-water end of the formula: K = 5.74·0.1^0.76 ≈ 1
    k = 5.74 * 0.1**0.76
    assert open_water == pytest.approx(k * 0.8 * 100.0 / 100.0)


def test_harbour_drafts_discharge_and_oscillate() -> None:
    tr = _truth("draft-harbour", 1800.0)
    t = tr["t_rel"]
    assert tr["mean_draft"][t < 50].mean() == pytest.approx(14.0 + 0.04 / 3, abs=1e-6)
    assert tr["mean_draft"][-1] == pytest.approx(10.0 + 0.04 / 3, abs=0.01)
    np.testing.assert_allclose(tr["trim"], 0.3, atol=1e-9)
    np.testing.assert_allclose(tr["list"], 0.05, atol=1e-9)
    wave = tr["draft_fore_stbd"] - tr["draft_fore_stbd_mean"]
    assert 0.1 < wave.std() * math.sqrt(2) < 1.0  # a regular 0.4 m sea moves the marks
    spectrum = np.abs(np.fft.rfft(wave))
    f = np.fft.rfftfreq(wave.size, t[1] - t[0])
    assert abs(1.0 / f[np.argmax(spectrum[1:]) + 1] - 12.0) < 0.5  # at rest: encounter = 12 s
