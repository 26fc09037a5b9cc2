"""The draft estimator's core on seeded synthetic hulls: what the chief officer reads,
through faulty marks, silence and jumps."""

from __future__ import annotations

import functools


import numpy as np
import pytest
from draft_stream import MARKS, T0, Hull, run

from edged.estimates import ESTIMATE_KINDS
from edged.records import Estimate, Measurement
from edged_draft.config import DraftConfig
from edged_draft.core import DraftCore


def _core(**kw) -> DraftCore:
    return DraftCore(DraftConfig(type="draft", stw_from=None, **kw))


def _rms(out, hull: Hull, field: str, after: float = 60.0) -> float:
    t = np.array([e.t - T0 for e in out])
    v = np.array([np.nan if e.values[field] is None else e.values[field] for e in out], dtype=float)
    truth = {"mean_draft": np.mean([hull.mark_mean(m, t) for m in MARKS], axis=0),
             "trim": np.full(len(t), hull.trim), "list": np.full(len(t), hull.list_)}[field]
    k = t > after
    return float(np.sqrt(np.nanmean((v - truth)[k] ** 2)))


def test_the_estimate_has_every_field_of_the_contract_once_a_second():
    hull = Hull(duration=40.0)
    out = run(_core(), hull.measurements())
    assert len(out) == 39
    names = set(ESTIMATE_KINDS["draft"].field_names) - {"t", "kind", "stale", "age", "converging"}  # the host's, or false when unset
    assert names <= set(out[-1].values)
    assert set(out[-1].values["marks"]) == set(MARKS)
    assert set(out[-1].values["marks"]["fore_port"]) == {"draft", "mean", "rate", "amplitude", "std", "ok"}
    assert all(m["ok"] for m in out[-1].values["marks"].values())


def test_a_rigid_hull_in_a_regular_sea():
    """Six marks σ 0.1 m at 100 Hz in a 12-s sea: mean draft, trim and list to a
    centimetre, each mark's instantaneous draft five times better than its readings."""
    hull = Hull(duration=240.0)
    out = run(_core(), hull.measurements())
    assert _rms(out, hull, "mean_draft") < 0.008
    assert _rms(out, hull, "trim") < 0.01
    assert _rms(out, hull, "list") < 0.01
    t = np.array([e.t - T0 for e in out])
    k = t > 60
    for m in MARKS:
        inst = np.array([e.values["marks"][m]["draft"] for e in out])
        truth = hull.mark_mean(m, t) + hull.mark_wave(m, t)
        assert np.sqrt(np.mean((inst - truth)[k] ** 2)) < 0.1 / 5, m


def _fault(start: float, end: float, how: str):
    def f(t: float, v: float, status: int):
        if not start <= t < end:
            return v, status
        if how == "status":
            return v + 3.0, 1  # a faulty sensor's value is anything
        if how == "silent":
            return None, status
        if how == "gaps":  # four readings in seven lost on the way, irregularly
            return (v, status) if (round(t * 100) * 2654435761) % 7 >= 4 else (None, status)
        return v + 0.5, status  # "jump"
    return f


@functools.lru_cache(maxsize=1)
def _clean_run() -> list:
    return run(_core(settle=20.0), Hull(duration=150.0).measurements())


@pytest.mark.parametrize("how", ["status", "silent", "gaps"])
def test_a_faulty_mark_is_left_out_filled_and_taken_back(how):
    hull = Hull(duration=150.0, faults={"fore_port": _fault(50.0, 90.0, how)})
    base = _clean_run()
    core = _core(settle=20.0)
    out = run(core, hull.measurements())
    assert len(out) == len(base)  # publishing throughout
    during = [e for e in out if T0 + 55 <= e.t < T0 + 90]
    assert during and not any(e.values["marks"]["fore_port"]["ok"] for e in during)
    bt = {e.t: e for e in base}
    worst = {f: max(abs(e.values[f] - bt[e.t].values[f]) for e in during) for f in ("mean_draft", "trim", "list")}
    assert worst["mean_draft"] < 0.025 and worst["trim"] < 0.10 and worst["list"] < 0.10
    assert out[-1].values["marks"]["fore_port"]["ok"]  # back, having agreed
    h = core.health()["marks"]["fore_port"]
    assert h[f"out.{how}"] == 1 and h["back"] == 1
    if how == "gaps":
        assert h["lost"] == pytest.approx(40 * 100 * 4 / 7, rel=0.02)


def test_a_mark_that_jumped_stays_out_and_says_by_how_much():
    """+0.5 m on one mark (5σ: the gate lets a reading in ten through, and the filter
    follows them): out within seconds, for good, trim and list unharmed."""
    hull = Hull(duration=200.0, faults={"aft_stbd": _fault(80.0, 1e9, "jump")})
    core = _core(settle=20.0)
    out = run(core, hull.measurements())
    assert not out[-1].values["marks"]["aft_stbd"]["ok"]
    h = core.health()
    assert h["marks"]["aft_stbd"]["out.disagrees"] == 1
    after = [e for e in out if e.t >= T0 + 80.0]
    assert all(v["ok"] for e in after for m, v in e.values["marks"].items() if m != "aft_stbd")
    out_ = [e for e in after if not e.values["marks"]["aft_stbd"]["ok"]]
    assert out_[0].t - T0 < 90.0
    for f, truth in (("trim", hull.trim), ("list", hull.list_)):
        assert max(abs(e.values[f] - truth) for e in out_) < 0.10
        assert max(abs(e.values[f] - truth) for e in after) < 0.15  # the seconds before it is found
    assert h["marks"]["aft_stbd"]["disagree"] == pytest.approx(0.5, abs=0.05)
    assert "aft_stbd" in h["filled"] and "aft_stbd" in h["out"]
    assert abs(out[-1].values["trim"] - hull.trim) < 0.03


def test_impossible_values_and_unknown_marks_are_counted_not_used():
    hull = Hull(duration=30.0, faults={"mid_port": lambda t, v, s: (99.0 if abs(t - 20.0) < 0.005 else v, s)})
    core = _core()
    ms = list(hull.measurements())
    ms.append(Measurement("draft", "can0.DraftMark", ms[-1].t, {"mark": "bow", "draft": 10.0, "status": 0}))
    out = run(core, ms)
    h = core.health()
    assert h["rejected"]["mid_port.range"] == 1 and h["rejected"]["draft.unknown_mark"] == 1
    assert out[-1].values["marks"]["mid_port"]["ok"]


def test_squat_ukc_and_cargo_need_the_vessel_and_come_with_it():
    hull = Hull(duration=120.0, mean=lambda t: 10.0 - 0.001 * t)
    plain = run(_core(), hull.measurements())
    assert all(plain[-1].values[f] is None for f in ("squat", "ukc", "displacement_change", "cargo_rate"))
    core = DraftCore(DraftConfig(type="draft", block_coefficient=0.8, tpc=100.0, mark_spacing=200.0,
                                 reference_after=40.0))
    ms = list(hull.measurements())
    # a sounder at midships on the keel, heaving with the ship over a seabed 18 m down
    w = 2 * np.pi / hull.period
    extra = [Measurement("depth", "sounder", T0 + k + 0.004,
                         {"depth": 18.0 - float(hull.mean(np.array([k]))[0]) - hull.heave * np.sin(w * (k + 0.004))})
             for k in range(120)]
    extra += [Estimate("stw", "stw", T0 + k, {"stw": 10 * 1852 / 3600, "stw_std": 0.05}) for k in range(120)]
    out = run(core, sorted(ms + extra, key=lambda r: r.t))
    v = out[-1].values
    assert v["squat"] == pytest.approx(0.8, rel=0.01)
    assert v["squat_std"] == pytest.approx(2 * 0.8 / (10 * 1852 / 3600) * 0.05, rel=0.01)
    # the water under the keel less the deepest mark's wave-free draft (aft port)
    deepest = hull.mean(np.array([119.0]))[0] + 0.15 + 0.025
    assert v["ukc"] == pytest.approx(18.0 - deepest, abs=0.02)
    # the change since the reference moment (the first estimate that has one) is
    # 100 t per cm of mean draft since then, and that is the hull's
    ref = next(e for e in out if e.values["displacement_change"] is not None)
    assert ref.values["displacement_change"] == 0.0
    assert v["displacement_change"] == pytest.approx(100 * 100 * (v["mean_draft"] - ref.values["mean_draft"]),
                                                     rel=1e-9)
    # (the level is still finding the rate of a discharge that was on from the start)
    assert v["mean_draft"] - ref.values["mean_draft"] == pytest.approx(-0.001 * (out[-1].t - ref.t), abs=0.02)
    # 1 mm/s of discharge at 100 t/cm: −10 t/s, 36,000 t/h
    assert v["cargo_rate"] == pytest.approx(-36_000, rel=0.2)
    # with σ: the true values within 3σ of what is read, and the σ not vacuous
    true_change = 100 * 100 * -0.001 * (out[-1].t - ref.t)
    print(f"change {v['displacement_change']:.0f} ± {v['displacement_change_std']:.0f} t (truth {true_change:.0f}), "
          f"rate {v['cargo_rate']:.0f} ± {v['cargo_rate_std']:.0f} t/h")
    assert abs(v["displacement_change"] - true_change) < 3 * v["displacement_change_std"] < 1.5 * abs(true_change)
    assert abs(v["cargo_rate"] + 36_000) < 3 * v["cargo_rate_std"] < 0.3 * 36_000
    assert 0.0 < v["mean_draft_std"] < 0.02 and v["filled"] == []


def test_bad_depths_stw_and_late_readings_are_counted_not_used():
    hull = Hull(duration=20.0)
    core = DraftCore(DraftConfig(type="draft"))
    ms = list(hull.measurements())
    ms.append(Measurement("depth", "sounder", ms[-1].t, {"depth": float("nan")}))
    ms.append(Measurement("depth", "sounder", ms[-1].t, {"depth": -3.0}))
    ms.append(Measurement("draft", "can0.DraftMark", ms[-1].t - 5.0, {"mark": "fore_port", "draft": 10.0, "status": 0}))
    ms.append(Estimate("stw", "stw", ms[-1].t + 5.0, {"stw": 400.0}))
    ms.append(Estimate("stw", "stw", ms[-1].t, {"stw": None}))
    run(core, ms)
    h = core.health()
    assert h["rejected"]["depth.bad_value"] == 2 and h["rejected"]["fore_port.late"] == 1
    assert h["rejected"]["stw.bad_value"] == 1
    assert h["depth"] is False and h["stw"] is False


def _speed(t):
    """10 kn for 40 s, then up to 15 kn in a minute (m/s)."""
    return 5.144 + 2.572 * np.clip((np.asarray(t) - 40.0) / 60.0, 0.0, 1.0)


def test_the_mean_draft_follows_a_squat_ramp_through_the_speed():
    # 5 cm of sinkage per (m/s)²: 1.3 m at 10 kn, 3.0 m at 15 kn; a sea of 15 s at 25 Hz
    hull = Hull(duration=160.0, rate=25.0, period=15.0, mean=lambda t: 10.0 + 0.05 * _speed(t) ** 2)
    rng = np.random.default_rng(3)
    # the STW estimate: 0.2 m/s high, scattered by 5 mm/s
    stw = [Estimate("stw", "stw", T0 + k, {"stw": float(_speed(k)) + 0.2 + 0.005 * rng.standard_normal()})
           for k in range(160)]
    ms = sorted(list(hull.measurements()) + stw, key=lambda r: r.t)
    cfg = {"block_coefficient": 0.8, "blockage": 0.25}
    core = DraftCore(DraftConfig(type="draft", **cfg))
    with_speed = _rms(run(core, ms), hull, "mean_draft")
    without = _rms(run(DraftCore(DraftConfig(type="draft", squat_from_speed=False, **cfg)), ms), hull,
                   "mean_draft")
    print(f"mean draft RMSE through the ramp: {with_speed * 100:.2f} cm with the speed, {without * 100:.2f} without")
    assert with_speed < 0.25 * without  # measured: 2.0 cm against 15.7
    # the 5 cm per (m/s)² the hull sank by, learned from Barrass's 6 cm (C_b 0.8, S 0.25)
    assert all(abs(k - 0.05) < 0.005 for k in core.health()["squat_coefficient"].values())
    assert with_speed < 0.03


def test_every_mark_out_makes_the_estimator_not_ok_and_says_why():
    """Six marks reading 0 (raw 0 on every frame: sensors in air or unpowered): no
    derived value, each reading counted `range`, and health's `problems` (which makes
    the worker `ok: false`) names each mark and its reason; with the marks sound again
    the problem is gone."""
    zero = {m: (lambda t, v, s: (0.0, s) if t < 40.0 else (v, s)) for m in MARKS}
    core = _core(settle=5.0)
    hull = Hull(duration=80.0, faults=zero)
    ms = list(hull.measurements())
    out = run(core, [m for m in ms if m.t < T0 + 30.0])
    assert all(e.values["mean_draft"] is None for e in out)
    assert core.health()["rejected"]["fore_port.range"] > 1000
    problems = core.health()["problems"]
    assert len(problems) == 1 and all(m in problems[0] for m in MARKS), problems
    run(core, [m for m in ms if m.t >= T0 + 30.0])
    assert core.health()["problems"] == []


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_derived_values_come_within_three_seconds_marked_converging(seed):
    """Issue 31: each mark settles 10 s before it is in, and a demo had no mean draft,
    trim or list for its first ten seconds. From EARLY_AFTER (2 s) they come from the
    starting marks' means, `converging`, the mean draft within its σ (measured:
    |error| ≤ 0.82 σ over seeds 0–3); then from the marks in, not converging."""
    hull = Hull(duration=20.0, seed=seed)
    out = run(_core(), hull.measurements())
    early = [e for e in out if 2.0 <= e.t - T0 < 3.5]
    assert early and all(e.values["mean_draft"] is not None and e.values["trim"] is not None
                         and e.values["list"] is not None and e.values["converging"] for e in early)
    for e in out:
        if e.values["mean_draft"] is None:
            continue
        truth = float(np.mean([hull.mark_mean(m, np.array([e.t - T0])) for m in MARKS]))
        assert abs(e.values["mean_draft"] - truth) < 2.0 * e.values["mean_draft_std"], (e.t - T0, e.values)
    assert not out[-1].values["converging"] and all(m["ok"] for m in out[-1].values["marks"].values())


def _mark_rms(out, hull: Hull, after: float = 60.0) -> dict[str, float]:
    res = {}
    for m in MARKS:
        t = np.array([e.t - T0 for e in out if e.t - T0 > after])
        v = np.array([e.values["marks"][m]["draft"] for e in out if e.t - T0 > after])
        res[m] = float(np.sqrt(np.mean((v - hull.mark_mean(m, t) - hull.mark_wave(m, t)) ** 2)))
    return res


def test_each_mark_reads_its_own_sea_where_no_rigid_motion_explains_the_marks():
    """Issue 31: a sea travelling along the hull (a quarter period from one station to
    the next) is no rigid heave, pitch and roll; the rigid fit put 2.6–17.2 cm of error
    on the marks' instantaneous drafts (raw σ 10 cm). Its χ² per dof (78) shows it, and
    each mark's own filtered sea is published: 1.2–1.7 cm (measured). On a rigid hull
    the fit is kept (χ² 0.56): 0.8–1.1 cm."""
    hull = Hull(duration=300.0, sea=0.3)
    core = _core()
    rms = _mark_rms(run(core, hull.measurements()), hull)
    assert not core.health()["rigid"]["used"]
    assert max(rms.values()) < 0.025, rms
    rigid = Hull(duration=300.0)
    core = _core()
    rms = _mark_rms(run(core, rigid.measurements()), rigid)
    assert core.health()["rigid"]["used"] and max(rms.values()) < 0.015, rms


def test_a_mark_stuck_at_one_value_is_counted_frozen_and_left_out():
    """The core's reject path for `frozen`: mid_port repeats 7.3 m exactly from 10 s on;
    after 30 s of it each reading is counted and not used, and the mark is out."""
    hull = Hull(duration=50.0, faults={"mid_port": lambda t, v, s: (7.3, s) if t >= 10.0 else (v, s)})
    core = _core()
    out = run(core, hull.measurements())
    h = core.health()
    assert h["rejected"]["mid_port.frozen"] > 500 and h["marks"]["mid_port"]["why"] == "frozen"
    assert not out[-1].values["marks"]["mid_port"]["ok"]


def test_health_has_the_shape_every_estimator_has_with_nis_per_mark():
    """The shared keys (`edged.estimator.HEALTH_KEYS`): the NIS of each mark's sensor
    (one dof), its gate rejections counted alike in `rejected` and `innovation`, a mark
    restarted after a jump counted as a reset; `seen` per input."""
    from edged.estimator import HEALTH_KEYS

    hull = Hull(duration=150.0, faults={"aft_stbd": lambda t, v, s: (v + 1.0 if t > 60.0 else v, s)})
    core = DraftCore(DraftConfig(type="draft", settle=20.0))
    run(core, hull.measurements())
    h = core.health()
    assert HEALTH_KEYS <= set(h)
    assert h["seen"] == {"depth": 0, "draft": 6 * 15000, "est/stw": 0}
    assert set(h["innovation"]) == set(MARKS)
    for mark, s in h["innovation"].items():
        assert s["dof"] == 1 and s["gated"] == h["rejected"].get(f"{mark}.gate", 0)
        if mark != "aft_stbd":
            assert 0.8 < s["nis_mean"] < 1.3 and s["in_band_95"] > 0.85, (mark, s)
    assert h["resets"] >= 1 and h["last_reset"].startswith("aft_stbd: ")


def test_what_the_core_consumes_is_known_from_its_configuration_alone():
    from edged_draft.plugin import DraftEstimator

    assert DraftCore.consumes(DraftConfig(type="draft")) == {"draft", "depth", "est/stw"}
    assert DraftCore.consumes(DraftConfig(type="draft", stw_from="stw_paper")) == {"draft", "depth", "est/stw_paper"}
    assert DraftCore.consumes(DraftConfig(type="draft", stw_from=None)) == {"draft", "depth"}
    assert DraftCore.ticks and DraftEstimator.Core is DraftCore
    assert _core().inputs == {"draft", "depth"}
