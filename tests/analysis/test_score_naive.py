"""`edged score`: the naive STW baseline, SOG − the latest current forecast along the course.

Issue 11 sets the STW estimate beside the Doppler log and beside what a crew does
without either: subtract the last forecast's current along the course from SOG. The
recordings are written with the project's recorder (conftest `make_rig`); every error
is chosen so that the figures are known by hand.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np
import pytest

from edged.cli import main as cli
from edged.estimates import ESTIMATE_KINDS
from edged.records import Estimate, Measurement
from edged_analysis.baselines import DERIVED, naive_stw

T0 = 1_732_350_000.0
NAIVE = "naive: sog - forecast along course"
GNSS = "/meas/velocity_ground/gnss1"
VDR = "/meas/current/vdr"


@pytest.fixture
def mcap(mcap: Callable[..., Path]) -> Callable[..., Path]:
    """The analysis tests' recording, its records in time order (hand-made here)."""
    return lambda records, **kw: mcap(sorted(records, key=lambda r: r.t), **kw)


@pytest.fixture
def truth_csv(tmp_path) -> Callable[..., Path]:
    def write(columns: dict[str, Iterable[float]]) -> Path:
        data = [list(v) for v in columns.values()]
        lines = [",".join(columns)] + [",".join(repr(float(c[i])) for c in data) for i in range(len(data[0]))]
        path = tmp_path / "truth.csv"
        path.write_text("\n".join(lines) + "\n")
        return path

    return write


def score_json(capsys, *args: str) -> list[dict[str, Any]]:
    rc = cli(["score", *args, "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    return json.loads(out)


def naive_rows(rows: list[dict[str, Any]], field: str = "stw") -> list[dict[str, Any]]:
    return [r for r in rows if r["field"] == field and r["baseline"] == NAIVE]


def stw(t: float, v: float = 5.0) -> Estimate:
    return Estimate("stw", "stw", t, {"stw": v, "sog": 6.0}, kind="stw")


def vel(t: float, sog: float, cog: float, source: str = "gnss1") -> Measurement:
    return Measurement("velocity_ground", source, t, {"sog": sog, "cog": cog})


def cur(t: float, set_: float | None, drift: float | None, source: str = "vdr") -> Measurement:
    return Measurement("current", source, t, {"set": set_, "drift": drift})


def hand_recording() -> list[Any]:
    """Truth stw = 5.0 throughout. Forecasts at +2 s (0.5 m/s toward north), +5 s
    (1.0 m/s toward east) and +7.5 s (0.2 m/s toward south)."""
    recs: list[Any] = [stw(T0 + i) for i in range(11)]
    recs += [cur(T0 + 2, 0.0, 0.5), cur(T0 + 5, math.pi / 2, 1.0), cur(T0 + 7.5, math.pi, 0.2)]
    recs += [
        vel(T0 + 1, 6.0, 0.0),  # before any forecast: no naive value
        vel(T0 + 2, 5.5, 0.0),  # forecast 1 (same instant): 5.5 − 0.5·cos 0 = 5.0 → 0
        vel(T0 + 4, 5.6, math.pi / 3),  # forecast 1: 5.6 − 0.5·cos(−60°) = 5.35 → +0.35
        vel(T0 + 5, 6.0, math.pi / 2),  # forecast 2 (same instant): 6.0 − 1.0 = 5.0 → 0 (forecast 1: +1.0)
        vel(T0 + 7, 5.0, math.pi),  # forecast 2, beam current: 5.0 − 0 → 0 (forecast 3, later: −0.2)
        vel(T0 + 8, 4.9, math.pi),  # forecast 3, following: 4.9 − 0.2 = 4.7 → −0.3
    ]
    recs += [Measurement("water_speed", "log1", T0 + i, {"stw_long": 5.3}) for i in range(11)]
    return recs


def test_naive_row_equals_the_hand_computation_beside_the_log(mcap, truth_csv, capsys):
    truth = truth_csv({"t": [T0, T0 + 100.0], "stw": [5.0, 5.0], "sog": [6.0, 6.0]})
    rows = score_json(capsys, str(mcap(hand_recording())), "--truth", str(truth), "--warmup", "0")

    (n,) = naive_rows(rows)
    errors = [0.0, 0.35, 0.0, 0.0, -0.3]
    assert n["n"] == 5  # the sample before the first forecast has no naive value
    assert n["rmse"] == pytest.approx(math.sqrt(sum(e * e for e in errors) / 5), abs=1e-12)
    assert n["bias"] == pytest.approx(0.01, abs=1e-12)
    assert n["max_abs"] == pytest.approx(0.35, abs=1e-12)  # forecast 1 at +5 s would give 1.0
    assert n["baseline_field"] == f"{GNSS}, {VDR}"  # which sources it was made from
    assert (n["estimate"], n["kind"], n["truth"], n["unit"]) == ("stw", "stw", "stw", "m/s")
    assert n["n_sigma"] is None and n["pct_1sigma"] is None

    order = [r["baseline"] for r in rows if r["field"] == "stw"]
    assert order == [None, "/meas/water_speed/log1", NAIVE]  # estimate, the log, then the naive one
    assert not naive_rows(rows, "sog") and not naive_rows(rows, "stw_long")


def test_a_later_forecast_is_not_used_for_an_earlier_sog(mcap, truth_csv, capsys):
    # One SOG sample 1 ms before a forecast that would make it exact: the earlier
    # forecast is the one a crew had.
    recs: list[Any] = [stw(T0 + i) for i in range(5)]
    recs += [cur(T0, 0.0, 0.5), cur(T0 + 2.001, 0.0, 1.0), vel(T0 + 2, 6.0, 0.0)]
    truth = truth_csv({"t": [T0, T0 + 10.0], "stw": [5.0, 5.0]})
    (n,) = naive_rows(score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "0"))
    assert n["n"] == 1 and n["bias"] == pytest.approx(0.5, abs=1e-12)  # 6.0 − 0.5, not 6.0 − 1.0


def test_warmup_applies_to_the_naive_row_as_to_the_log(mcap, truth_csv, capsys):
    truth = truth_csv({"t": [T0, T0 + 100.0], "stw": [5.0, 5.0]})
    rows = score_json(capsys, str(mcap(hand_recording())), "--truth", str(truth), "--warmup", "4.5")
    (n,) = naive_rows(rows)
    assert n["n"] == 3  # +5, +7, +8 s
    assert n["bias"] == pytest.approx(-0.1, abs=1e-12) and n["max_abs"] == pytest.approx(0.3, abs=1e-12)
    log = [r for r in rows if r["baseline"] == "/meas/water_speed/log1"]
    assert [r["n"] for r in log if r["field"] == "stw"] == [6]  # +5 .. +10 s


def test_no_naive_row_without_currents_or_without_velocity(mcap, truth_csv, capsys):
    truth = truth_csv({"t": [T0, T0 + 100.0], "stw": [5.0, 5.0], "sog": [6.0, 6.0]})
    est = [stw(T0 + i) for i in range(10)]
    no_current = mcap(est + [vel(T0 + i, 6.0, 0.0) for i in range(10)], name="a.mcap")
    rows = score_json(capsys, str(no_current), "--truth", str(truth), "--warmup", "0")
    assert not naive_rows(rows) and any(r["baseline"] == GNSS for r in rows)  # SOG still has its row

    no_velocity = mcap(est + [cur(T0 + i, 0.0, 0.5) for i in range(10)], name="b.mcap")
    assert not naive_rows(score_json(capsys, str(no_velocity), "--truth", str(truth), "--warmup", "0"))

    # Forecasts only after the last SOG, or without drift: nothing to compute, no row.
    late = mcap(est + [vel(T0 + 1, 6.0, 0.0), cur(T0 + 5, 0.0, 0.5), cur(T0, 0.0, None)], name="c.mcap")
    assert not naive_rows(score_json(capsys, str(late), "--truth", str(truth), "--warmup", "0"))


def test_one_row_per_pair_of_sources(mcap, truth_csv, capsys):
    recs: list[Any] = [stw(T0 + i) for i in range(10)]
    for i in range(10):
        recs += [vel(T0 + i, 5.5, 0.0, "gnss1"), vel(T0 + i + 0.5, 5.7, 0.0, "gnss2")]
    recs += [cur(T0, 0.0, 0.5, "vdr"), cur(T0, 0.0, 0.4, "zenoh")]
    truth = truth_csv({"t": [T0, T0 + 100.0], "stw": [5.0, 5.0]})
    rows = naive_rows(score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "0"))
    got = {r["baseline_field"]: round(r["bias"], 9) for r in rows}
    assert got == {
        f"{GNSS}, {VDR}": 0.0,
        f"{GNSS}, /meas/current/zenoh": 0.1,
        f"/meas/velocity_ground/gnss2, {VDR}": 0.2,
        "/meas/velocity_ground/gnss2, /meas/current/zenoh": 0.3,
    }
    assert all(r["n"] == 10 for r in rows)


def test_seeded_voyage_matches_a_loop_over_the_forecasts(mcap, truth_csv, capsys):
    # 1 Hz SOG/COG of a vessel turning through north, forecasts at irregular times:
    # the recording's naive row equals a plain loop over the forecasts known so far.
    rng = np.random.default_rng(11)
    n = 600
    tv = T0 + np.arange(n, dtype=float)
    cog = np.mod(np.linspace(5.5, 7.5, n), 2 * math.pi)
    sog = 6.0 + rng.normal(0.0, 0.1, n)
    tc = T0 + np.sort(np.r_[30.5, rng.uniform(31.0, 590.0, 7)])  # the first before the warm-up ends
    set_ = rng.uniform(0.0, 2 * math.pi, 8)
    drift = rng.uniform(0.0, 1.0, 8)
    truth_stw = 5.5 + 0.001 * np.arange(n)
    recs: list[Any] = [stw(float(t)) for t in tv]
    recs += [vel(float(t), float(s), float(c)) for t, s, c in zip(tv, sog, cog)]
    recs += [cur(float(t), float(a), float(d)) for t, a, d in zip(tc, set_, drift)]
    truth = truth_csv({"t": tv, "stw": truth_stw})
    warmup = 120.0
    (row,) = naive_rows(score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", str(warmup)))

    errs = []
    for i in range(n):
        known = [k for k in range(8) if tc[k] <= tv[i]]
        if tv[i] < T0 + warmup or not known:
            continue
        k = known[-1]
        errs.append(sog[i] - drift[k] * math.cos(set_[k] - cog[i]) - truth_stw[i])
    e = np.array(errs)
    assert row["n"] == len(errs) == n - 120
    assert row["rmse"] == pytest.approx(float(np.sqrt(np.mean(e * e))), rel=1e-9)
    assert row["bias"] == pytest.approx(float(e.mean()), rel=1e-9, abs=1e-12)
    assert row["max_abs"] == pytest.approx(float(np.abs(e).max()), rel=1e-9)


def test_the_table_names_the_naive_row_and_its_sources(mcap, truth_csv, capsys):
    truth = truth_csv({"t": [T0, T0 + 100.0], "stw": [5.0, 5.0]})
    assert cli(["score", str(mcap(hand_recording())), "--truth", str(truth), "--warmup", "0"]) == 0
    lines = capsys.readouterr().out.splitlines()
    (line,) = [ln for ln in lines if NAIVE in ln]
    assert line.startswith(" ") and f"vs {NAIVE} ({GNSS}, {VDR})" in line
    assert line.split()[-10:-6] == ["5", "0.2062", "0.01", "0.35"]
    assert line.isascii()


def test_naive_stw_function():
    t_v = np.array([0.0, 1.0, 2.0, 3.0])
    got = naive_stw(
        t_v, np.array([5.0, 5.0, np.nan, 5.0]), np.array([0.0, 0.0, 0.0, math.pi]),
        np.array([0.5, 1.0, 2.5]), np.array([0.0, np.nan, 0.0]), np.array([1.0, 2.0, 0.5]),
    )
    # t=0 before any forecast; t=1 the forecast without a set is ignored; t=2 no SOG;
    # t=3 uses the forecast at 2.5, flowing against the course: 5 + 0.5.
    assert np.isnan(got[0]) and got[1] == pytest.approx(4.0) and np.isnan(got[2]) and got[3] == pytest.approx(5.5)
    assert np.isnan(naive_stw(t_v, np.ones(4), np.zeros(4), np.array([]), np.array([]), np.array([]))).all()


def test_every_declared_derived_baseline_is_computed():
    names = {d for k in ESTIMATE_KINDS.values() for f in k.scored_fields() for d in f.derived}
    assert "naive_stw" in names and names <= set(DERIVED)
    assert all(DERIVED[d].label.isascii() for d in names)
