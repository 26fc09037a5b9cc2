"""The manoeuvre core as the worker host drives it: starting, what it publishes, and
what it does with sensors that are not what the configuration says."""

from __future__ import annotations

import math

import numpy as np
import pytest
from manoeuvre_stream import T0, Manoeuvre, run, truth_at
from pydantic import ValidationError

from edged.estimates import ESTIMATE_KINDS
from edged.geo import LocalPlane
from edged.records import Estimate, Measurement
from edged_manoeuvre.config import ManoeuvreConfig
from edged_manoeuvre.core import ManoeuvreCore
from edged_manoeuvre.predict import ellipse
from edged_manoeuvre.update import SPARSE_FIX

STRAIGHT = Manoeuvre(duration=90.0, heading_deg=30.0)


def _core(**kw) -> ManoeuvreCore:
    return ManoeuvreCore(ManoeuvreConfig(type="manoeuvre", **kw))


def _voyage(base: Manoeuvre = STRAIGHT, **kw) -> Manoeuvre:
    return Manoeuvre(**{**base.__dict__, "truth": [], **kw})


def test_the_estimate_has_every_field_of_the_contract():
    core = _core()
    out = run(core, _voyage().measurements())
    e = out[-1]
    names = set(ESTIMATE_KINDS["manoeuvre"].field_names) - {"t", "kind", "stale", "age"}  # the host's
    assert names <= set(e.values), names - set(e.values)
    v = e.values
    assert v["model"] == "ctra" and v["filter"] == "ekf"
    assert {"x", "y", "u", "v", "heading", "r", "a_u", "a_v"} <= set(v["std"])
    assert [p["dt"] for p in v["predicted"]][:4] == pytest.approx([10.0, 30.0, 60.0, 120.0], abs=1.0)
    assert 0.0 <= v["heading"] < 2 * math.pi and 0.0 <= v["cog"] < 2 * math.pi
    assert v["drift_angle"] == pytest.approx(math.atan2(v["v"], v["u"]))
    assert v["drift_angle_water"] is None  # no current known


def test_nothing_is_published_before_a_heading_and_a_second_of_fixes():
    core = _core()
    plane = LocalPlane(57.6, 11.5)
    for k in range(30):  # positions only
        lat, lon = plane.to_geodetic(0.5 * k, 0.0)
        core.step(Measurement("position", "gnss", T0 + 0.1 * k, {"lat": lat, "lon": lon}))
    assert core.tick(T0 + 3.0) == []
    assert "heading" in core.health()["missing"]
    core.step(Measurement("heading", "gyro", T0 + 3.0, {"heading": 0.0}))
    lat, lon = plane.to_geodetic(15.0, 0.0)
    core.step(Measurement("position", "gnss", T0 + 3.0, {"lat": lat, "lon": lon}))
    (e,) = core.tick(T0 + 3.05)
    # started from the line through the last second of fixes: 5 m/s north
    assert e.values["u"] == pytest.approx(5.0, abs=0.01) and e.values["v"] == pytest.approx(0.0, abs=0.01)


def test_paper_mode_starts_from_two_fixes_with_the_papers_p0():
    """Eqs. (16)-(22): velocity from two-point differencing, P0 with R/Δt and 2R/Δt²."""
    core = _core(mode="paper")
    plane = LocalPlane(57.6, 11.5)
    core.step(Measurement("heading", "gyro", T0, {"heading": 0.0}))
    for k, n in enumerate((0.0, 0.6)):
        lat, lon = plane.to_geodetic(n, 0.0)
        core.step(Measurement("position", "gnss", T0 + 0.1 * k, {"lat": lat, "lon": lon}))
    f = core.filter
    assert f is not None and f.x[2] == pytest.approx(6.0, abs=1e-4)  # u = Δn/Δt
    R11 = 1.0  # Table 3: σ = 1 m
    assert f.P[0, 0] == pytest.approx(R11) and f.P[2, 2] == pytest.approx(2 * R11 / 0.01, rel=1e-5)
    assert f.P[0, 2] == pytest.approx(R11 / 0.1)
    assert core.cfg.substep == 0.005 and not core.cfg.adapt_q and not core.cfg.imu_bias


def test_a_gnss_jump_just_after_the_start_starts_the_filter_again():
    """The same 150 m jump 3 s after the filter started: the fixes it started from may
    have been the wrong ones (a start velocity the accelerometers cannot correct keeps
    every later fix out), so it starts again from the fixes, says so in health, and
    has the right velocities after."""
    voyage = _voyage()
    ms = list(voyage.measurements())
    probe = _core()
    started = None
    for m in ms:
        probe.step(m)
        if probe.filter is not None:
            started = m.t
            break
    assert started is not None
    plane = LocalPlane(57.6, 11.5)
    fed = []
    for m in ms:
        if m.kind == "position" and started + 3.0 <= m.t < started + 13.0:
            n, e = plane.to_ne(m.values["lat"], m.values["lon"])
            lat, lon = plane.to_geodetic(n, e + 150.0)
            m = Measurement("position", m.source, m.t, {"lat": lat, "lon": lon})
        fed.append(m)
    core = _core()
    out = run(core, fed)
    h = core.health()
    assert h["events"].get("start_again") == 2 and "position_jump" not in h["events"]
    assert core.divergences == 0
    late = [e for e in out if e.t > started + 45.0]
    tr = voyage.truth
    assert late and max(abs(e.values["u"] - truth_at(tr, e.t)[3]) for e in late) < 0.1
    assert max(abs(e.values["v"] - truth_at(tr, e.t)[4]) for e in late) < 0.1


def test_a_gnss_jump_is_kept_out_then_taken_as_the_new_position():
    """150 m east for 10 s (the `faults` scenario's jump): gated five times, then the
    position starts again from the fixes; velocities never jump."""
    voyage = _voyage()
    core = _core()
    plane = LocalPlane(57.6, 11.5)
    ms = []
    for m in voyage.measurements():
        if m.kind == "position" and 50.0 <= m.t - T0 < 60.0:
            n, e = plane.to_ne(m.values["lat"], m.values["lon"])
            lat, lon = plane.to_geodetic(n, e + 150.0)
            m = Measurement("position", m.source, m.t, {"lat": lat, "lon": lon})
        ms.append(m)
    out = run(core, ms)
    h = core.health()
    assert h["rejected"]["position.gate"] >= 10 and h["events"]["position_jump"] == 2
    assert core.divergences == 0
    late = [e for e in out if e.t - T0 > 75.0]
    tr = voyage.truth
    assert max(abs(e.values["u"] - truth_at(tr, e.t)[3]) for e in late) < 0.1
    assert max(abs(e.values["v"] - truth_at(tr, e.t)[4]) for e in late) < 0.1


def _spoil_blown_up(f) -> None:
    f.P = np.diag(np.full(len(f.x), 1e30))  # every variance beyond physical sense


def _spoil_singular(f) -> None:
    big = np.zeros_like(f.P)
    big[0:2, 0:2] = 1e20  # north and east perfectly correlated: S has rank 1
    f.P = f.P + big


@pytest.mark.parametrize("spoil", [_spoil_blown_up, _spoil_singular], ids=["blown_up", "singular_S"])
def test_a_diverged_filter_is_counted_and_starts_again(spoil):
    voyage = _voyage()
    core = _core()
    ms = list(voyage.measurements())
    half = len(ms) // 2
    run(core, ms[:half])
    spoil(core.filter)
    out = run(core, ms[half:])
    assert core.divergences == 1 and core.health()["events"]["diverged"] == 1
    h = core.health()
    assert h["resets"] == 1 and ("rcond" in h["last_reset"] or "variance" in h["last_reset"])
    assert out and core.filter is not None  # running again from the next measurements
    last = out[-1]
    assert abs(last.values["u"] - truth_at(voyage.truth, last.t)[3]) < 0.2


def test_the_plane_moves_with_the_vessel_without_a_jump():
    voyage = _voyage(duration=150.0, u=20.0)  # 3 km
    core = _core(origin_radius=1000.0)
    out = run(core, voyage.measurements())
    assert core.health()["events"]["origin_moved"] >= 2
    plane = LocalPlane(57.6, 11.5)
    errs = []
    for e in out[200:]:
        n, ea = plane.to_ne(e.values["lat"], e.values["lon"])
        tr = truth_at(voyage.truth, e.t)
        errs.append(math.hypot(n - tr[1], ea - tr[2]))
    assert max(errs) < 3.0  # metres, whatever the origin


def test_each_sensors_noise_is_learned():
    """A 3 m GNSS and a 0.3° gyro configured as 1.5 m and 0.2°: learned within 15 %,
    and their NIS back near its degrees of freedom."""
    voyage = _voyage(duration=240.0, position_sigma=3.0, heading_sigma_deg=0.3)
    core = _core()
    run(core, voyage.measurements())
    h = core.health()
    pos = h["sensor_sigma"]["position/gnss"]
    hdg = h["sensor_sigma"]["heading/gyro"]
    assert pos == pytest.approx([3.0, 3.0], rel=0.15)
    assert math.degrees(hdg[0]) == pytest.approx(0.3, rel=0.15)
    assert h["innovation"]["position"]["nis_mean"] == pytest.approx(2.0, rel=0.3)


def test_sensors_faster_than_ten_hertz_are_averaged():
    core = _core()
    run(core, _voyage(duration=60.0).measurements())
    upd = core.health()["innovation"]
    # 50 Hz rate gyro and accelerometers: about 10 updates a second each, not 50
    assert 450 < upd["yaw_rate"]["updates"] < 620 and 450 < upd["accel"]["updates"] < 620
    assert 550 < upd["position"]["updates"] < 620  # 10 Hz: sample by sample
    every = _core(max_rate=0.0)
    run(every, _voyage(duration=60.0).measurements())
    assert every.health()["innovation"]["yaw_rate"]["updates"] > 2800


def test_drift_through_the_water_with_a_known_current():
    core = _core()
    ms = list(_voyage().measurements())
    # 0.5 m/s toward the east
    ms.insert(5, Measurement("current", "forecast", ms[5].t, {"set": math.pi / 2, "drift": 0.5}))
    out = run(core, ms)
    v = out[-1].values
    psi = v["heading"]
    cu, cv = 0.5 * math.sin(psi), 0.5 * math.cos(psi)
    assert v["drift_angle_water"] == pytest.approx(math.atan2(v["v"] - cv, v["u"] - cu), abs=1e-9)
    # its value and sign: heading 030° at u 6, v +0.2 m/s over ground, the current
    # setting east sets her to port through the water: atan2(0.2 − 0.433, 6 − 0.25)
    truth = math.atan2(0.2 - 0.5 * math.cos(math.radians(30.0)), 6.0 - 0.5 * math.sin(math.radians(30.0)))
    assert truth < 0.0 and v["drift_angle_water"] == pytest.approx(truth, abs=math.radians(0.3))
    assert v["drift_angle"] == pytest.approx(math.atan2(0.2, 6.0), abs=math.radians(0.3))  # starboard over ground
    # a current three hours old says nothing any more
    core._current = (core._current[0] - 4 * 3600.0, *core._current[1:])
    assert core.tick(ms[-1].t + 0.1)[0].values["drift_angle_water"] is None


def test_drift_through_the_water_from_the_stw_estimator():
    core = _core(current_from="stw")
    assert "est/stw" in core.inputs
    ms = list(_voyage().measurements())
    out = []
    for i, m in enumerate(ms):
        core.step(m)
        if i == 50:
            core.step(Estimate("stw", "stw", m.t, {"current": 0.5, "current_set": math.pi / 2}))
    out = core.tick(ms[-1].t + 0.05)
    truth = math.atan2(0.2 - 0.5 * math.cos(math.radians(30.0)), 6.0 - 0.5 * math.sin(math.radians(30.0)))
    assert out[0].values["drift_angle_water"] == pytest.approx(truth, abs=math.radians(0.3))


def test_prediction_of_a_steady_turn_follows_the_circle_and_its_ellipse_grows():
    voyage = _voyage(duration=300.0, r_deg=0.5, heading_deg=0.0)
    core = _core()
    out = run(core, voyage.measurements())
    plane = LocalPlane(57.6, 11.5)
    # from when the 60-s predictions that came due (over 2 horizons, `blend.py`) have
    # shown the model better than dead reckoning
    fresh = [e for e in out if e.t - T0 > 190.0 and e.values["predicted"][0]["dt"] == 10.0
             and e.t - T0 + 60.0 <= voyage.duration]
    assert fresh
    weights = core.health()["prediction"]["60"]["weights"]
    assert weights["model"] + weights["model_low_rate"] > 0.9, weights
    model_err, dr_err = [], []
    for e in fresh:
        p60 = next(p for p in e.values["predicted"] if p["dt"] == 60.0)
        tr = truth_at(voyage.truth, e.t + 60.0)
        n, ea = plane.to_ne(p60["lat"], p60["lon"])
        model_err.append(math.hypot(n - tr[1], ea - tr[2]))
        # straight-line dead reckoning from the estimate's own SOG/COG
        n0, e0 = plane.to_ne(e.values["lat"], e.values["lon"])
        sog, cog = e.values["sog"], e.values["cog"]
        dr_err.append(math.hypot(n0 + 60 * sog * math.cos(cog) - tr[1], e0 + 60 * sog * math.sin(cog) - tr[2]))
        majors = [p["std_major"] for p in e.values["predicted"]]
        assert majors == sorted(majors)
    assert np.sqrt(np.mean(np.square(model_err))) < 0.2 * np.sqrt(np.mean(np.square(dr_err)))


def test_ellipse_axes_and_angle():
    major, minor, angle = ellipse(np.array([[1.0, 0.0], [0.0, 4.0]]))  # long east-west
    assert (major, minor) == pytest.approx((2.0, 1.0)) and angle == pytest.approx(math.pi / 2)
    major, minor, angle = ellipse(np.array([[2.0, 1.0], [1.0, 2.0]]))  # along 045°
    assert major == pytest.approx(math.sqrt(3.0)) and angle == pytest.approx(math.pi / 4)


def test_bad_inputs_are_counted_not_used():
    core = _core()
    ms = list(_voyage(duration=30.0).measurements())
    run(core, ms)
    core.step(Measurement("position", "gnss", ms[-1].t + 0.1, {"lat": float("nan"), "lon": 11.5}))
    core.step(Measurement("position", "gnss", ms[-1].t + 0.1, {"lat": 57.6, "lon": 11.5, "fix_quality": 0}))
    core.step(Measurement("heading", "gyro", ms[-1].t - 5.0, {"heading": 0.1}))
    h = core.health()
    assert h["rejected"]["position.no_fix"] == 2 and h["rejected"]["heading.late"] == 1


@pytest.mark.parametrize("filt", ["ekf", "ukf", "enkf"])
def test_every_filter_runs_in_a_process_of_its_own_by_default(filt):
    """(issue 34: beside the inputs on another core, not in the event loop's time)"""
    assert ManoeuvreConfig(type="manoeuvre", filter=filt).worker == "process"
    assert ManoeuvreConfig(type="manoeuvre", filter=filt, worker="loop").worker == "loop"


def test_config_errors_name_the_key():
    with pytest.raises(ValidationError, match="horizons"):
        ManoeuvreConfig(type="manoeuvre", horizons=[10.0, -5.0])
    with pytest.raises(ValidationError, match="filter"):
        ManoeuvreConfig(type="manoeuvre", filter="pf")
    with pytest.raises(ValidationError, match="members"):
        ManoeuvreConfig(type="manoeuvre", filter="enkf", members=1)


def test_one_fix_told_three_times_is_one_update():
    """GGA, RMC and GLL of one receiver carry the same fix: counted as repeats."""
    core = _core()
    ms = []
    for m in _voyage(duration=30.0).measurements():
        ms.append(m)
        if m.kind == "position":
            ms += [Measurement("position", m.source, m.t, dict(m.values))] * 2
    run(core, ms)
    h = core.health()
    assert h["rejected"]["position.repeat"] == 2 * 301
    assert h["innovation"]["position"]["updates"] < 301


def test_one_gyro_heard_twice_is_used_once_and_a_second_receiver_stands_by():
    """HDT and PGN 127250 of one gyro (the same readings, rounded otherwise) are one
    sensor: the copy is muted, and takes over when the first falls silent. Of two GNSS
    receivers (errors not independent, antennas apart) the first heard is used, the
    other stands by and takes over when the first falls silent."""
    voyage = _voyage(duration=60.0)
    rng = np.random.default_rng(9)
    plane = LocalPlane(57.6, 11.5)
    ms = []
    for m in voyage.measurements():
        ms.append(m)
        if m.kind == "heading" and m.t - T0 < 40.0:  # the copy, rounded to 0.01°
            h = math.radians(round(math.degrees(m.values["heading"]), 2))
            ms.append(Measurement("heading", "n2k.18", m.t + 0.002, {"heading": h}))
        if m.kind == "heading" and m.t - T0 >= 40.0:  # the first falls silent
            ms[-1] = Measurement("heading", "n2k.18", m.t, dict(m.values))
        if m.kind == "position":  # a second receiver, its own noise
            n, e = plane.to_ne(m.values["lat"], m.values["lon"])
            lat, lon = plane.to_geodetic(n + rng.normal(0, 1.5), e + rng.normal(0, 1.5))
            ms.append(Measurement("position", "gnss2", m.t + 0.003, {"lat": lat, "lon": lon}))
            if m.t - T0 >= 50.0:  # the first receiver falls silent
                ms.remove(m)
    core = _core()
    run(core, ms)
    h = core.health()
    assert h["duplicates"] == ["heading: gyro = n2k.18"]
    assert 300 < h["muted"]["heading"] <= 400  # the copy while the first spoke (40 s at 10 Hz)
    assert 490 < h["muted"]["position"] <= 521  # the second receiver while the first spoke (50 s, 2 s failover)
    assert h["innovation"]["position"]["updates"] > 560  # it took over after 50 s
    assert h["problems"] == []
    assert h["innovation"]["heading"]["updates"] > 550  # the copy took over after 40 s
    assert "heading/n2k.18" in h["sensor_sigma"] and "position/gnss2" in h["sensor_sigma"]


def _share_in_2_sigma(out: list, voyage: Manoeuvre, horizon: float) -> float:
    plane = LocalPlane(57.6, 11.5)
    inside = []
    for e in out:
        if e.t - T0 < 120.0 or e.t - T0 + horizon > voyage.duration:
            continue
        p = next(p for p in e.values["predicted"] if p["dt"] == horizon)  # made at this tick
        tr = truth_at(voyage.truth, e.t + horizon)
        n, ea = plane.to_ne(p["lat"], p["lon"])
        dn, de = tr[1] - n, tr[2] - ea
        a = p["std_angle"]
        along, across = dn * math.cos(a) + de * math.sin(a), -dn * math.sin(a) + de * math.cos(a)
        inside.append((along / p["std_major"]) ** 2 + (across / p["std_minor"]) ** 2 <= 4.0)
    assert len(inside) > 100
    return float(np.mean(inside))


def test_a_prediction_ellipse_from_a_process_noise_far_too_high_is_sized_by_the_fixes():
    """The configured yaw and jerk noise a hundred times what a steady turn needs: the
    model's 2-σ ellipse at 30 s holds every truth with metres to spare; sized by the
    fixes that came due, it is a tenth as large and still holds the truth (more often
    than the Gaussian 86.5 %: it cannot be sized below the fixes' own noise)."""
    voyage = _voyage(duration=300.0, r_deg=0.3, heading_deg=0.0)
    kw = {"q_yaw_accel": 1e-5, "q_jerk": 1e-2, "predict_rate": 0.0}
    raw, sized = _core(ellipse_window=0.0, **kw), _core(**kw)
    out_raw, out_sized = run(raw, voyage.measurements()), run(sized, voyage.measurements())
    assert _share_in_2_sigma(out_raw, voyage, 30.0) == 1.0
    assert 0.8 < _share_in_2_sigma(out_sized, voyage, 30.0) < 1.0
    assert raw.health()["ellipse_scale"]["30"] == 1.0
    assert sized.health()["ellipse_scale"]["30"] < 0.1
    major = [next(p["std_major"] for p in o[-1].values["predicted"] if p["dt"] == 30.0) for o in (out_raw, out_sized)]
    assert major[1] < 0.1 * major[0]


def test_a_thirty_day_gap_starts_the_filter_again_with_bounded_work(monkeypatch):
    import edged_manoeuvre.core as core_mod
    import edged_manoeuvre.ekf as ekf_mod

    spans: list[float] = []
    real_transition = ekf_mod.transition

    def transition(F, f, x, dt, substep):
        spans.append(dt)
        return real_transition(F, f, x, dt, substep)

    monkeypatch.setattr(ekf_mod, "transition", transition)
    assert not hasattr(core_mod, "rk4")  # a tick publishes the state as it is: no integration
    gap = 30 * 86400.0
    first = _voyage(duration=60.0)
    second = _voyage(duration=60.0, heading_deg=200.0, seed=3)
    ms = list(first.measurements()) + [
        Measurement(m.kind, m.source, m.t + gap, m.values) for m in second.measurements()]
    core = _core()
    out = run(core, ms, bound=1000)
    h = core.health()
    assert h["events"].get("gap") == 1 and h["last_reset"] == "a gap of 2591940 s in every input"
    assert max(spans) <= core.cfg.reset_after  # never integrated across the gap
    after = [e for e in out if e.t > T0 + gap]
    assert after and all(e.t <= T0 + gap + 60.1 for e in after)
    assert after[0].values["converging"] is True and after[-1].values["converging"] is False
    # the second voyage's estimate is its own: heading 200°, not the first one's 30°
    tr = truth_at(second.truth, after[-1].t - gap)
    assert abs(wrap(after[-1].values["heading"] - tr[5])) < math.radians(0.5)
    assert after[-1].values["u"] == pytest.approx(tr[3], abs=0.05)


def test_a_gap_shorter_than_reset_after_is_integrated_across():
    first = _voyage(duration=60.0)
    ms = list(first.measurements())
    ms = [m for m in ms if not (T0 + 30.0 < m.t < T0 + 40.0)]  # 10 s without any input
    core = _core()
    out = run(core, ms, bound=1000)
    assert "gap" not in core.health()["events"]
    assert out[-1].values["converging"] is False


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


@pytest.mark.parametrize("with_sog", [True, False])
def test_a_gnss_with_a_fix_every_30_s_starts_the_filter(with_sog):
    """A ship's receiver thinned to a fix every 30 s never gives three fixes in 10 s:
    the filter starts from the last fix and the receiver's SOG/COG, or from two fixes."""
    voyage = _voyage(duration=240.0, gnss_hz=10.0)
    ms = []
    for m in voyage.measurements():
        if m.kind == "position":
            if round(m.t - T0, 3) % 30.0:
                continue
            if with_sog:
                tr = truth_at(voyage.truth, m.t)
                vn = tr[3] * math.cos(tr[5]) - tr[4] * math.sin(tr[5])
                ve = tr[3] * math.sin(tr[5]) + tr[4] * math.cos(tr[5])
                ms.append(m)
                ms.append(Measurement("velocity_ground", "gnss", m.t + 0.01,
                                      {"sog": math.hypot(vn, ve), "cog": math.atan2(ve, vn) % (2 * math.pi)}))
                continue
        ms.append(m)
    ms.sort(key=lambda m: m.t)
    core = _core()
    out = run(core, ms)
    assert out, "the filter never started"
    assert out[0].t - T0 <= (6.0 if with_sog else 31.0)  # with SOG/COG: once no second fix came in 5 s
    for e in out[-300::30]:  # the last 30 s: within 3σ and a tenth of a m/s
        tr = truth_at(voyage.truth, e.t)
        for i, f in ((3, "u"), (4, "v")):
            err = abs(e.values[f] - tr[i])
            assert err <= min(0.1, 3.0 * e.values["std"][f]), (f, err, e.values["std"][f])


def _with_fault(voyage: Manoeuvre, kind: str, start: float, end: float, change) -> list[Measurement]:
    """The voyage's measurements with those of `kind` in [start, end) s changed by
    `change(m) -> Measurement | None` (None drops it)."""
    out = []
    for m in voyage.measurements():
        if m.kind == kind and start <= m.t - T0 < end:
            m = change(m)
            if m is None:
                continue
        out.append(m)
    return out


def _within(out: list, voyage: Manoeuvre, fields=((3, "u"), (4, "v"))) -> dict[str, tuple[float, float]]:
    """Per field over `out`: (the share of estimates within ±3σ of the truth, the
    largest |error| / σ)."""
    z: dict[str, list[float]] = {f: [] for _, f in fields}
    for e in out:
        tr = truth_at(voyage.truth, e.t)
        for i, f in fields:
            err = abs(e.values[f] - tr[i]) if f != "heading" else abs(wrap(e.values[f] - tr[i]))
            z[f].append(err / e.values["std"][f])
    return {f: (float(np.mean(np.array(v) <= 3.0)), max(v)) for f, v in z.items()}


def _honest(worst: dict[str, tuple[float, float]]) -> bool:
    """±3σ holds 97 % (the issue's bar outside fault windows) and nothing beyond 5σ."""
    return all(share >= 0.97 and top < 5.0 for share, top in worst.values())


def test_saturated_accelerometers_are_left_out_and_named():
    """0x320 at 32.767 m/s² (the int16's largest, in its DBC's range) for 10 s: kept out
    by range, named in problems while it lasts, the estimate within its σ throughout."""
    voyage = _voyage(duration=120.0, orders=((50.0, 0.5, 0.0, 0.0),))
    sat = {"ax": 32.767, "ay": 32.767, "az": 32.767}
    ms = _with_fault(voyage, "accel_body", 60.0, 70.0, lambda m: Measurement(m.kind, m.source, m.t, sat))
    core = _core()
    noted: dict = {T0 + 65.0: None, T0 + 100.0: None}
    out = run(core, ms, problems=noted)
    said = list(noted.values())
    h = core.health()
    assert h["rejected"]["accel.range"] == 500 and h["divergences"] == 0
    assert said[0] and said[0][0].startswith("accel/imu: reading 32.8 m/s²") and said[1] == []
    worst = _within([e for e in out if e.t - T0 > 10.0], voyage)
    assert _honest(worst), worst


def test_a_frozen_compass_is_left_out_while_the_gyro_turns_and_the_heading_stays_honest():
    """The compass repeats its last heading for 60 s of a turn at 1°/s: after three
    repetitions against the gyro it is left out, after 2° of turn named; the heading
    coasts on the gyro with an honest σ and is the compass's again when it moves."""
    voyage = _voyage(duration=180.0, r_deg=1.0)
    frozen: dict[str, float] = {}

    def freeze(m):
        frozen.setdefault("h", m.values["heading"])
        return Measurement(m.kind, m.source, m.t, {"heading": frozen["h"]})

    ms = _with_fault(voyage, "heading", 40.0, 100.0, freeze)  # 60 s of a steady turn at 1°/s
    core = _core()
    noted: dict = {T0 + 70.0: None}
    out = run(core, ms, problems=noted)
    said = noted[T0 + 70.0]
    h = core.health()
    assert h["rejected"]["heading.frozen"] > 500
    assert said and said[0].startswith("heading/gyro: frozen at ")
    worst = _within([e for e in out if e.t - T0 > 10.0], voyage, ((5, "heading"), (3, "u"), (4, "v")))
    assert _honest(worst), worst
    after = [e for e in out if e.t - T0 > 130.0]  # 30 s after the compass came back
    assert max(abs(wrap(e.values["heading"] - truth_at(voyage.truth, e.t)[5])) for e in after) < math.radians(0.1)


def test_a_position_jumping_10_km_for_60_s_is_held_out_and_named():
    voyage = _voyage(duration=200.0)
    plane = LocalPlane(57.6, 11.5)

    def jump(m):
        n, e = plane.to_ne(m.values["lat"], m.values["lon"])
        lat, lon = plane.to_geodetic(n + 10_000.0, e)
        return Measurement(m.kind, m.source, m.t, {**m.values, "lat": lat, "lon": lon})

    ms = _with_fault(voyage, "position", 60.0, 120.0, jump)
    core = _core()
    noted: dict = {T0 + 90.0: None}
    out = run(core, ms, problems=noted)
    said = noted[T0 + 90.0]
    assert said and said[0].startswith("position/gnss: fixes 10.0 km from the track")
    assert core.health()["events"].get("position_jump") is None
    for e in out:
        if e.t - T0 > 10.0:
            n, ea = plane.to_ne(e.values["lat"], e.values["lon"])
            tr = truth_at(voyage.truth, e.t)
            err = math.hypot(n - tr[1], ea - tr[2])
            assert err < max(3.0 * math.hypot(e.values["std"]["x"], e.values["std"]["y"]), 5.0), (e.t - T0, err)


def test_a_filter_far_from_the_gnss_sog_is_restarted():
    voyage = _voyage(duration=60.0)
    core = _core()
    ms = list(voyage.measurements())
    run(core, [m for m in ms if m.t - T0 < 30.0])
    core.filter.x[2] += 50.0  # u 50 m/s too fast: a filter that lost itself
    rng = np.random.default_rng(2)
    for k in range(5):
        t = T0 + 30.0 + 0.2 * k
        tr = truth_at(voyage.truth, t)
        vn = tr[3] * math.cos(tr[5]) - tr[4] * math.sin(tr[5]) + rng.normal(0, 0.03)
        ve = tr[3] * math.sin(tr[5]) + tr[4] * math.cos(tr[5]) + rng.normal(0, 0.03)
        core.step(Measurement("velocity_ground", "gnss", t, {"sog": math.hypot(vn, ve), "cog": math.atan2(ve, vn) % (2 * math.pi)}))
    h = core.health()
    assert h["divergences"] == 1 and h["last_reset"].startswith("velocity 50.")


def test_without_an_imu_the_sog_is_no_worse_than_the_gnss_its_doppler_velocity_gives():
    """A yacht's suite: GNSS at 1 Hz with its SOG/COG, a 1° compass at 1 Hz, no rate
    gyro, no IMU. The receiver's Doppler velocity is an update of the velocity over
    ground: the estimate's SOG is no worse than the receiver's (without it, differencing
    fixes against a swinging compass made it 100 times worse in `edged sim yacht:yacht`)."""
    voyage = _voyage(duration=300.0, gnss_hz=1.0, heading_hz=1.0, heading_sigma_deg=1.0, position_sigma=2.5,
                     orders=((100.0, 1.0, 0.0, 0.0), (160.0, 0.0, 0.0, 0.0)))
    rng = np.random.default_rng(5)
    ms, raw = [], []
    for m in voyage.measurements():
        if m.kind in ("yaw_rate", "accel_body"):
            continue
        ms.append(m)
        if m.kind == "position":
            tr = truth_at(voyage.truth, m.t)
            vn = tr[3] * math.cos(tr[5]) - tr[4] * math.sin(tr[5]) + rng.normal(0, 0.065)
            ve = tr[3] * math.sin(tr[5]) + tr[4] * math.cos(tr[5]) + rng.normal(0, 0.065)
            sog = math.hypot(vn, ve)
            ms.append(Measurement("velocity_ground", "gnss", m.t + 0.01, {"sog": sog, "cog": math.atan2(ve, vn) % (2 * math.pi)}))
            raw.append(sog - math.hypot(tr[3], tr[4]))
    core = _core()
    out = [e for e in run(core, ms) if e.t - T0 > 30.0]
    err = [e.values["sog"] - math.hypot(*truth_at(voyage.truth, e.t)[3:5]) for e in out]
    assert np.sqrt(np.mean(np.square(err))) <= np.sqrt(np.mean(np.square(raw[30:]))), (
        np.sqrt(np.mean(np.square(err))), np.sqrt(np.mean(np.square(raw[30:]))))
    assert core.health()["innovation"]["velocity"]["updates"] > 250


@pytest.mark.parametrize("seed", [1, 2])
def test_a_filter_sure_of_a_wrong_speed_starts_again_at_the_first_gnss_epoch_against_it(seed):
    """GNSS every 30 s with SOG/COG. The filter is told it goes 3 m/s faster than she does
    and is sure of it (as a yacht in a seaway between 30-s fixes once was of 0 m/s):
    the next epoch's fix and SOG/COG both fail their gates. One story, not two outliers:
    the filter starts again from that fix and SOG/COG at once (before, the velocity's
    five-in-a-row check took 2.5 minutes)."""
    voyage = _voyage(duration=200.0, gnss_hz=10.0, seed=seed)
    rng = np.random.default_rng(seed)
    ms = []
    for m in voyage.measurements():
        if m.kind == "position":
            if round(m.t - T0, 3) % 30.0:
                continue
            tr = truth_at(voyage.truth, m.t)
            vn = tr[3] * math.cos(tr[5]) - tr[4] * math.sin(tr[5]) + rng.normal(0.0, 0.05)
            ve = tr[3] * math.sin(tr[5]) + tr[4] * math.cos(tr[5]) + rng.normal(0.0, 0.05)
            ms += [m, Measurement("velocity_ground", "gnss", m.t + 0.01,
                                  {"sog": math.hypot(vn, ve), "cog": math.atan2(ve, vn) % (2 * math.pi)})]
            continue
        ms.append(m)
    ms.sort(key=lambda m: m.t)
    core = _core()
    cut = next(i for i, m in enumerate(ms) if m.t - T0 > 95.0)
    run(core, ms[:cut])
    f = core.filter
    assert f is not None
    f.x[2] += 3.0  # u
    f.P[2, :] *= 1e-3
    f.P[:, 2] *= 1e-3
    out = run(core, ms[cut:])
    h = core.health()
    assert h["events"].get("diverged") == 1 and "a manoeuvre the filter missed" in h["last_reset"], h["last_reset"]
    after = [e for e in out if e.t - T0 > 120.5]  # the epoch at 120 s restarted it
    assert after and after[0].t - T0 < 126.0  # from its fix and SOG/COG once no second fix came in 5 s
    assert all(abs(e.values["u"] - truth_at(voyage.truth, e.t)[3]) < 0.3 for e in after)


def _yaw_errors(out: list, voyage: Manoeuvre, after: float = 60.0) -> tuple[float, float]:
    """RMS error of r (°/s) and of the heading (°) over the estimates after `after` s."""
    truth = np.array([(row[0] - T0, row[5], row[6]) for row in voyage.truth])
    psi = np.unwrap(truth[:, 1])
    er, eh = [], []
    for e in out:
        if e.t - T0 < after:
            continue
        er.append(math.degrees(e.values["r"] - np.interp(e.t - T0, truth[:, 0], truth[:, 2])))
        eh.append(math.degrees(wrap(e.values["heading"] - np.interp(e.t - T0, truth[:, 0], psi))))
    return float(np.sqrt(np.mean(np.square(er)))), float(np.sqrt(np.mean(np.square(eh))))


@pytest.mark.parametrize("seed", [1, 2])
def test_a_yacht_yawing_in_a_seaway_is_followed_as_closely_as_her_gyro_reads(seed):
    """A yacht yawing ±5° at 4 s (r ±7.9 °/s) with a 50 Hz rate gyro (0.01 °/s, averaged
    to 10 Hz blocks stamped behind the 10 Hz compass) and a 0.1° compass. With r held
    between readings (the paper's ṙ = 0, `yaw_accel_tau = 0`) the estimated r is
    0.33 °/s off and the heading 0.31° (3 × the compass's error); with the yaw
    acceleration a state and the blocks carried to the state's time, r 0.074–0.075 °/s
    and the heading 0.015–0.016° (seeds 1–3, measured)."""
    voyage = Manoeuvre(duration=180.0, u=4.0, v=0.1, seed=seed, wave_yaw=(5.0, 4.0))
    out = run(_core(), list(voyage.measurements()))
    r_rms, h_rms = _yaw_errors(out, voyage)
    assert r_rms < 0.12, r_rms
    assert h_rms < 0.03, h_rms  # under a third of the compass's error
    paper_like = run(_core(yaw_accel_tau=0.0), list(voyage.measurements()))
    assert _yaw_errors(paper_like, voyage)[0] > 3 * r_rms  # what the state is for


def test_an_estimate_is_the_state_at_its_newest_measurement_published_once():
    """A tick publishes the state at the newest measurement's time, not run on to the
    tick's (r held over 0.1 s of wave yaw cost a yacht 0.7 °/s), and once: a second
    tick with nothing new publishes nothing (the host's `stale_after` says so later)."""
    voyage = Manoeuvre(duration=20.0, seed=3)
    ms = list(voyage.measurements())
    core = _core()
    run(core, ms)
    last = max(m.t for m in ms)
    out = core.tick(last + 0.05)
    assert len(out) == 1 and out[0].t == pytest.approx(core.t) and core.t <= last + 1e-9
    assert core.tick(last + 0.15) == []


def _u_rms(out: list, voyage: Manoeuvre, after: float = 120.0) -> float:
    truth = np.array([(row[0] - T0, row[3]) for row in voyage.truth])
    e = [x.values["u"] - np.interp(x.t - T0, truth[:, 0], truth[:, 1]) for x in out if x.t - T0 > after]
    return float(np.sqrt(np.mean(np.square(e))))


@pytest.mark.xfail(strict=True, reason=(
    "not met (issue 30): a yacht yawing ±5° at 4 s about a steady track, fixes every 30 s "
    "and an IMU: her sway acceleration (±0.41 m/s²) cancels u·r in the lateral "
    "accelerometer, the random-walk a_v cannot follow it, and the update takes it out of "
    "u: u 3.0–4.9 m/s off (IMU at 1, 10 or 50 Hz), 0.17–0.38 without the IMU. The "
    "slow accelerometer's R raised by u²σ_r² (`_slow_accel_R`) halved the error in "
    "edged sim's yacht:sparse, not here; it needs the wave's sway in the model."))
@pytest.mark.parametrize("seed", [1])
def test_an_imu_does_not_spoil_a_yacht_yawing_about_her_track_between_sparse_fixes(seed):
    voyage = Manoeuvre(duration=600.0, u=3.0, v=0.2, seed=seed, wave_yaw=(5.0, 4.0), steady_course=True,
                       gnss_hz=1, heading_hz=10, imu_hz=1)
    ms = [m for m in voyage.measurements()
          if m.kind != "position" or abs((m.t - T0) / 30.0 - round((m.t - T0) / 30.0)) < 1e-6]
    with_imu = _u_rms(run(_core(), ms), voyage)
    without = _u_rms(run(_core(), [m for m in ms if m.kind != "accel_body"]), voyage)
    assert with_imu <= 1.2 * without, (with_imu, without)


def test_a_slow_accelerometers_noise_grows_with_the_wave_yaw_it_cannot_follow():
    """`_slow_accel_R`: R + diag(v², u²)·σ_r², σ_r² the variance of r about its 20-s
    mean over 10 s: nothing on a steady heading, (3 m/s × 0.12 rad/s)² = 0.13 m²/s⁴ on
    the lateral row of a yacht yawing ±5° at 4 s."""
    steady = Manoeuvre(duration=60.0, u=3.0, v=0.2, seed=4, imu_hz=1)
    core = _core()
    run(core, list(steady.measurements()))
    R0 = np.diag([4e-4, 4e-4])
    assert np.allclose(core._slow_accel_R(R0), R0, atol=2e-5)
    yawing = Manoeuvre(duration=60.0, u=3.0, v=0.2, seed=4, imu_hz=1, wave_yaw=(5.0, 4.0), steady_course=True)
    core = _core()
    run(core, list(yawing.measurements()))
    lateral = core._slow_accel_R(R0)[1, 1] - R0[1, 1]
    assert 0.05 < lateral < 0.3, lateral


def test_the_wave_yaws_accelerometer_noise_only_between_sparse_fixes():
    """`_between_fixes`: where the GNSS speaks each second it holds u and v itself, and
    raising a 1 Hz accelerometer's R by the wave yaw only threw away the surge it sees
    (edged sim yacht:coastal over 1800 s: SOG 0.72 → 1.67 × the GNSS's, COG 1.40 →
    2.44 ×); more than SPARSE_FIX s after the last fix it carries the motion alone and
    its R takes in the wave yaw (yacht:sparse: position 22 → 12.9 × the fix)."""
    voyage = Manoeuvre(duration=60.0, u=3.0, v=0.2, seed=4, imu_hz=1, gnss_hz=1,
                       wave_yaw=(5.0, 4.0), steady_course=True)
    core = _core()
    ms = list(voyage.measurements())
    run(core, ms)
    last_fix = max(m.t for m in ms if m.kind == "position")
    assert not core._between_fixes(last_fix + 0.5)
    assert core._between_fixes(last_fix + SPARSE_FIX + 0.5)


@pytest.mark.parametrize("q_yaw_jerk", [1e-7, 0.04, 1.0])
def test_the_prediction_does_not_carry_the_waves_yaw_noise_minutes_ahead(q_yaw_jerk):
    """The yaw acceleration is the wave's (τ of seconds): its noise, integrated into the
    turn rate as a random walk over two minutes, gave a 120-s ellipse of 10⁸ m across
    the track (the demo, every scenario with the tuned default). The predictor holds
    the turn rate: the yaw acceleration's value, variance and noise are left out, so
    the ellipses stay what the turn rate's own uncertainty makes them."""
    from edged_manoeuvre.model import PSI

    core = _core(q_yaw_jerk=q_yaw_jerk)
    i = core.model.yaw.index
    assert i is not None  # the tuned default has the yaw acceleration state
    n = core.process.Qc.shape[0]
    x = np.zeros(n)
    x[2] = 5.0  # 5 m/s north
    P = np.eye(n) * 1e-6  # (the turn rate known to 0.06 °/s)
    P[i, i] = 0.5  # a wave's yaw acceleration, uncertain
    Qc = core.process.Qc.copy()
    Qc[i, i] = q_yaw_jerk
    runs = core.forecast.predictor.run(x, P, Qc)
    rows = core.forecast.predictor.predicted(runs, lambda n_, e_: (57.6 + n_ / 111_000.0, 11.5))
    majors = {r["dt"]: r["std_major"] for r in rows}
    assert majors[120.0] < 1000.0, majors  # metres, not the 10⁸ of before
    assert runs[-1][2][PSI, PSI] < 1.0  # the heading's variance stays below a radian²
