"""Start-up, gaps, the log under test and health problems of the STW estimator (issue 30).

Each test feeds a seeded synthetic voyage (`stw_stream.Voyage`) straight into the core;
each takes a few seconds. Thresholds sit at a stated margin from the figure measured
when they were set (in the comment beside each).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from edged.records import Measurement
from edged_stw.config import StwConfig
from edged_stw.core import StwCore
from stw_stream import T0, Voyage, run


def core(**kw) -> StwCore:
    return StwCore(StwConfig(type="stw", **kw))


def shifted(ms, after: float, by: float):
    """The stream with everything from `after` s on moved `by` s later (a gap)."""
    return [Measurement(m.kind, m.source, m.t + by, m.values, m.t_src) if m.t >= T0 + after else m for m in ms]


def test_start_from_positions_alone_publishes_nothing_until_the_speed_is_known():
    """bundg/furuno: a fix before any SOG started the filter at 0 ± 14 m/s and published it."""
    ms = [m for m in Voyage(duration=300, seed=11).measurements() if m.kind != "velocity_ground"]
    c = core()
    est = run(c, ms)
    assert est
    first = est[0].values
    assert first["stw_std"] < 1.5  # measured 1.05 (the current's σ; no forecast before the first fix)
    assert abs(first["sog"] - math.hypot(*Voyage().ground_velocity())) < 1.0
    conv = [e.values["converging"] for e in est]
    assert conv[-1] is False
    # While it converges σ still covers the error (an honest start).
    assert all(abs(e.values["sog"] - 10.7) <= 3 * max(e.values["stw_std"], 0.1) + 0.3 for e in est)


def test_a_six_hour_gap_restarts_the_filter_and_the_distance_goes_on():
    v = Voyage(duration=1800, seed=12)
    ms = shifted(list(v.measurements()), after=900, by=6 * 3600)
    c = core()
    est = run(c, ms)
    h = c.health()
    assert h["resets"] == 1 and "no GNSS for 2160" in h["last_reset"]
    # No estimate inside the gap, and none made up across it.
    assert not [e for e in est if T0 + 900 + c.cfg.reset_after < e.t < T0 + 900 + 6 * 3600]
    after = [e.values for e in est if e.t > T0 + 6 * 3600 + 1300]  # after the next forecast (1200 s)
    assert after and max(abs(x["stw"] - v.speed) for x in after) < 0.5  # measured 0.12
    d = [e.values["distance"] for e in est]
    assert all(b >= a - 1e-6 for a, b in zip(d, d[1:]))  # never backwards
    # 1800 s at 10.7 m/s over ground: 19.3 km made good; the gap adds its straight line
    # (here 1 s: the stream goes on where it stopped) and the reset_after s of dead
    # reckoning published before the gap was known to be one (measured 21.1 km).
    sog = math.hypot(*v.ground_velocity())
    assert 0.98 * 1800 * sog <= d[-1] <= 1.02 * (1800 + c.cfg.reset_after) * sog
    # The forecast from before the gap is 6 h old (forecast_max_age 3 h): not reused; the
    # next one makes the current known again.
    assert after[-1]["stw_std"] < 0.3  # measured 0.15


def test_gap_restart_bounds_the_work_of_a_step():
    """A 30-day gap: the first step after it costs no more than any other step."""
    import time

    ms = shifted(list(Voyage(duration=300, seed=13).measurements()), after=150, by=30 * 86400)
    c = core()
    t0 = time.process_time()
    est = run(c, ms)
    assert time.process_time() - t0 < 5.0
    assert all(math.isfinite(e.values["stw"]) and e.values["stw"] < 15.0 for e in est)


@pytest.fixture(scope="module")
def dead_log():
    """3 h at 10 m/s, the log reading 0 from 1 h to 2 h."""
    ms = []
    for m in Voyage(duration=3 * 3600, seed=14).measurements():
        if m.kind == "water_speed" and T0 + 3600 <= m.t < T0 + 7200:
            m = Measurement(m.kind, m.source, m.t, {"stw_long": 0.0, "stw_trans": 0.0})
        ms.append(m)
    c = core()
    seen = []
    out = []
    nxt = math.floor(ms[0].t) + 1.0
    for m in ms:
        while nxt <= m.t:
            for e in c.tick(nxt):
                out.append(e)
                seen.append((nxt, list(c.health()["problems"]), e.values["dvl_bias"]))
            nxt += 1.0
        c.step(m)
    return c, out, seen


def test_a_log_reading_zero_is_named_in_problems_and_left_out(dead_log):
    c, est, seen = dead_log
    during = [(t, p, b) for t, p, b in seen if T0 + 3600 + 120 <= t < T0 + 7200]
    assert during and all(any("Doppler log reads 0.00" in x for x in p) for _, p, _ in during)
    assert all(b is None for _, _, b in during)  # no offset published while the log is out
    # Taken back after it reads again, and its offset is the one before the fault.
    late = [(t, p, b) for t, p, b in seen if t > T0 + 7200 + 300]
    assert late and not late[-1][1]
    last = est[-1].values
    assert last["dvl_bias"] == pytest.approx(0.3, abs=0.1)  # measured 0.29 ± 0.05
    assert not c.health()["warnings"] or "high" in c.health()["warnings"][0]


def test_no_forecast_no_log_offset_and_no_warning_about_the_log():
    """aava/plaka: without a forecast, dvl − SOG = b − current along: b is not observable."""
    c = core()
    est = run(c, Voyage(forecasts=False, dvl_offset=-1.0, duration=1800, seed=15).measurements())
    assert all(e.values["dvl_bias"] is None for e in est)
    h = c.health()
    assert not h["warnings"]
    assert h["dvl"]["published"] is False and "no current forecast" in h["dvl"]["reason"]
    assert h["rejected"]["water_speed.no_current"] > 1000


def test_a_warning_about_the_log_only_when_its_offset_is_significant():
    c = core()
    run(c, Voyage(dvl_offset=0.05, duration=3600, seed=16).measurements())
    assert not c.health()["warnings"]  # 0.05 m/s against a 0.2 tolerance
    c = core()
    run(c, Voyage(dvl_offset=-0.8, duration=3600, seed=16).measurements())
    assert c.health()["warnings"] and "low" in c.health()["warnings"][0]


def test_heading_wander_without_a_forecast_invents_no_current_along_the_ship():
    """aava: a yacht steered ±10° by hand, no forecast. Heading − course sees the current
    across the ship; along the ship it would see only the wander times the speed. The
    current along stays unknown (σ of the prior), never a confident made-up value."""
    v = Voyage(speed=3.5, heading_deg=200.0, current_set_deg=20.0, current_drift=0.6, wander_deg=10.0,
               wander_period=240.0, heading_noise_deg=2.0, forecasts=False, imu=False, duration=1800, seed=17)
    c = core()
    est = run(c, v.measurements())
    late = [e.values for e in est if e.t > T0 + 600]
    err = np.array([x["stw"] - v.speed for x in late])
    sd = np.array([x["stw_std"] for x in late])
    assert np.all(np.abs(err) <= 3 * sd)
    assert np.min(sd) > 0.5  # measured 0.96: the along current is not known


@pytest.mark.parametrize("seed", [21, 22])
def test_gnss_noisier_than_configured_is_a_problem_naming_it(seed):
    """SOG 10× noisier than its σ: the velocity NIS stays far out of its band."""
    rng = np.random.default_rng(seed)
    ms = []
    for m in Voyage(duration=900, seed=seed).measurements():
        if m.kind == "velocity_ground":
            vn = m.values["sog"] * math.cos(m.values["cog"]) + rng.normal(0, 0.65)
            ve = m.values["sog"] * math.sin(m.values["cog"]) + rng.normal(0, 0.65)
            m = Measurement(m.kind, m.source, m.t, {"sog": math.hypot(vn, ve), "cog": math.atan2(ve, vn) % (2 * math.pi)})
        ms.append(m)
    c = core()
    run(c, ms)
    problems = c.health()["problems"]
    assert any(p.startswith("velocity_ground:") for p in problems), problems


def test_a_consistent_voyage_has_no_problems():
    c = core()
    run(c, Voyage(duration=1800, seed=23).measurements())
    assert c.health()["problems"] == []


#: A varied voyage: 8 → 10 m/s from 30 min (10-min ramp), a 60° turn in 2 min at 1 h,
#: a current of 0.8 m/s turning 30°/h; a rate-of-turn sensor; 1.5 h.
VARIED = dict(duration=5400, speed=8.0, speed2=10.0, speed_at=1800, speed_ramp=600, turn_deg=60, turn_at=3600,
              turn_time=120, current_set_deg=225.0, current_drift=0.8, current_rotation_deg_h=30.0, rot=True)


def _scored(v: Voyage, after: float = 1200.0) -> dict[str, float]:
    ms = list(v.measurements())
    est = [e for e in run(core(), ms) if e.t >= T0 + after]

    def sog_true(k: float) -> float:
        u, h = v.speed_at_t(k)[0], v.heading_at_t(k)[0]
        c_n, c_e = v.current_at_t(k)
        return math.hypot(u * math.cos(h) + c_n, u * math.sin(h) + c_e)

    err = np.array([e.values["stw"] - v.truth(e.t - T0) for e in est])
    sd = np.array([e.values["stw_std"] for e in est])
    sog = np.array([e.values["sog"] - sog_true(e.t - T0) for e in est])
    raw = np.array([m.values["sog"] - sog_true(m.t - 0.2 - T0) for m in ms
                    if m.kind == "velocity_ground" and m.t >= T0 + after])
    return {"stw": float(np.sqrt(np.mean(err**2))), "cov3": float(np.mean(np.abs(err) <= 3 * sd)),
            "sog": float(np.sqrt(np.mean(sog**2))), "raw": float(np.sqrt(np.mean(raw**2)))}


@pytest.mark.parametrize("seed", [1, 3])
def test_gnss_every_30_s_and_an_imu_at_1_hz_a_turn_and_a_speed_change(seed):
    """A large ship's suite (issue 30): the estimate's SOG was twice as noisy as the GNSS
    SOG it reads (0.142 against 0.064 on the simulator), and a turn between 30-s fixes
    shortened the velocity to 2 m/s under the truth. Measured (seed 1, 3): SOG 0.065,
    0.055 against the raw 0.062, 0.060; STW 0.164, 0.083; within ±3σ 100 %."""
    r = _scored(Voyage(seed=seed, gnss_period=30, imu_hz=1, **VARIED))
    assert r["sog"] <= 1.15 * r["raw"], r
    assert r["stw"] < 0.22, r
    assert r["cov3"] >= 0.97, r


@pytest.mark.parametrize("seed", [1, 2])
def test_a_varied_voyage_at_1_hz(seed):
    """The same voyage with GNSS at 1 Hz and the IMU at 10 Hz. Measured (seed 1, 2): SOG
    0.022–0.024 against 0.065 raw, STW 0.142, 0.063 (the forecasts' error, σ 0.2 every
    20 min), within ±3σ 100 %."""
    r = _scored(Voyage(seed=seed, **VARIED))
    assert r["sog"] <= 0.6 * r["raw"], r
    assert r["stw"] < 0.2, r
    assert r["cov3"] >= 0.97, r


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_an_order_to_slow_down_between_30_s_fixes_is_followed_once_the_gnss_shows_it(seed):
    """A laden ship holding her speed for 40 minutes teaches the filter that her
    acceleration never changes (jerk density ~1e-7); then 7 → 5 m/s in 60 s, GNSS every
    30 s, a 1 Hz IMU whose noise (σ 0.05 m/s²) hides the −0.033 m/s². The first epoch
    whose position and velocity both fail the gate is one story, not two outliers: the
    filter starts again from the GNSS there. Before, both were rejected for ten fixes
    (generalise.py, tanker:fog: the SOG 1.5 m/s high for two minutes).
    Measured over the 5 minutes from the third fix after the order (seed 1, 2, 3): SOG
    error RMS 0.11, 0.18, 0.21 m/s, largest 0.33, 0.70, 0.52 (seed 1: the accelerometers'
    lean seen by the drift watch, before the GNSS; before the watch 0.14, 0.40); without
    the joint reset RMS 0.55, 0.58, 1.43, largest 1.3, 1.5, 1.9."""
    v = Voyage(seed=seed, speed=7.0, speed2=5.0, speed_at=2400.0, speed_ramp=60.0, duration=3000, gnss_period=30,
               imu_hz=1, current_drift=0.3)
    ms = list(v.measurements())
    c = core()
    est = run(c, ms)
    third = [m.t for m in ms if m.kind == "velocity_ground" and m.t - T0 > 2400.0][2]

    def sog_true(k: float) -> float:
        u, h = v.speed_at_t(k)[0], v.heading_at_t(k)[0]
        c_n, c_e = v.current_at_t(k)
        return math.hypot(u * math.cos(h) + c_n, u * math.sin(h) + c_e)

    err = np.array([e.values["sog"] - sog_true(e.t - T0) for e in est if third + 1.0 <= e.t <= third + 300.0])
    assert err.size > 250
    assert np.sqrt(np.mean(err**2)) < 0.3 and np.abs(err).max() < 0.9, (np.sqrt(np.mean(err**2)), np.abs(err).max())
    # noticed: by the accelerometers' innovations leaning one way (ground.DriftWatch),
    # or where the IMU's noise hides it, by the joint reset
    noticed = c.model.ground.manoeuvres > 0 or "manoeuvre it missed" in (c.monitor.last_reset or "")
    assert noticed, (c.model.ground.manoeuvres, c.monitor.last_reset)


def test_health_has_the_shape_every_estimator_has():
    """The shared keys (`edged.estimator.HEALTH_KEYS`), `seen` listing every input,
    then the STW core's own; what it consumes is known without making a core."""
    from edged.estimator import HEALTH_KEYS
    from edged_stw.plugin import StwEstimator

    c = core()
    run(c, Voyage(duration=300, seed=31, dvl=False).measurements())
    h = c.health()
    assert HEALTH_KEYS <= set(h) and {"mode", "missing", "dvl", "warnings"} <= set(h)
    assert h["seen"]["water_speed"] == 0 and h["seen"]["position"] == 300 and len(h["seen"]) == 7
    assert set(h["seen"]) == StwCore.consumes(c.cfg) == c.inputs
    assert StwCore.ticks and StwEstimator.Core is StwCore
