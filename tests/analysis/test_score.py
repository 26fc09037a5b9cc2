"""`edged score`: estimates of a recording against a truth table (DESIGN §4).

Recordings are written with the project's own recorder (conftest `make_rig`), truth
tables by hand; errors are synthetic so that every figure is known in advance.
"""

from __future__ import annotations

import io
import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np
import pytest

from edged.cli import main as cli
from edged.records import Estimate, Measurement
from edged_analysis.figures import field_errors, figures
from edged.geo import EARTH_RADIUS
from edged_analysis.truth import ScoreError, load_truth

T0 = 1_732_350_000.0
DEG = math.pi / 180.0


# -- helpers ---------------------------------------------------------------------------
@pytest.fixture
def truth_csv(tmp_path) -> Callable[..., Path]:
    """Write a truth table from columns (t first); extra raw lines appended as given."""

    def write(columns: dict[str, Iterable[float]], extra: Sequence[str] = (), name: str = "truth.csv") -> Path:
        names = list(columns)
        data = [list(v) for v in columns.values()]
        lines = [",".join(names)]
        lines += [",".join(repr(float(c[i])) for c in data) for i in range(len(data[0]))]
        path = tmp_path / name
        path.write_text("\n".join([*lines, *extra]) + "\n")
        return path

    return write


def score_json(capsys, *args: str) -> tuple[list[dict[str, Any]], str]:
    rc = cli(["score", *args, "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    return json.loads(out), err


def row(rows: list[dict[str, Any]], field: str, baseline: str | None = None, estimate: str | None = None) -> dict[str, Any]:
    (r,) = [
        r for r in rows
        if r["field"] == field and r["baseline"] == baseline and (estimate is None or r["estimate"] == estimate)
    ]
    return r


def stw(t: float, **values: Any) -> Estimate:
    return Estimate("stw", "stw", t, values, kind="stw")


# -- figures -------------------------------------------------------------------------
def test_known_rmse_bias_max_and_autocorrelation(mcap, truth_csv, capsys):
    # Truth rises linearly, so interpolating it to the estimates' half-second times is
    # exact; stw errs by 0.2 ± 0.1 alternating, sog by a constant 0.05.
    k = np.arange(201)
    truth = truth_csv({"t": T0 + k, "stw": 5.0 + 0.01 * k, "sog": np.full(201, 6.0)})
    recs = [
        stw(T0 + i + 0.5, stw=5.0 + 0.01 * (i + 0.5) + 0.2 + 0.1 * (-1) ** i, stw_std=0.25, sog=6.05)
        for i in range(200)
    ]
    rows, err = score_json(capsys, str(mcap(recs)), "--truth", str(truth))

    s = row(rows, "stw")
    assert s["n"] == 140  # t − t_first ≥ 60 s: i = 60 .. 199
    assert s["unit"] == "m/s" and s["truth"] == "stw"
    assert s["bias"] == pytest.approx(0.2, abs=1e-9)
    assert s["rmse"] == pytest.approx(math.sqrt(0.2**2 + 0.1**2), abs=1e-9)
    assert s["max_abs"] == pytest.approx(0.3, abs=1e-9)
    assert s["n_sigma"] == 140
    assert s["pct_1sigma"] == pytest.approx(50.0)  # |0.1| ≤ 0.25 < |0.3|
    assert s["pct_2sigma"] == s["pct_3sigma"] == 100.0
    assert s["ac1"] == pytest.approx(-139 / 140, abs=1e-6)  # alternating: −(n−1)/n
    assert s["ac10"] == pytest.approx(130 / 140, abs=1e-6)
    assert s["ac60"] == pytest.approx(80 / 140, abs=1e-6)

    g = row(rows, "sog")
    assert (g["n"], g["bias"], g["rmse"], g["max_abs"]) == (140, pytest.approx(0.05), pytest.approx(0.05), pytest.approx(0.05))
    assert g["n_sigma"] is None and g["pct_1sigma"] is None  # sog has no σ
    assert g["ac1"] is None  # a constant error has no autocorrelation
    assert "no column" in err and "stw_long" in err  # the fields truth cannot judge


def test_sigma_coverage_of_gaussian_errors_with_the_right_sigma(mcap, truth_csv, capsys):
    rng = np.random.default_rng(20241123)
    n = 10_000
    sig = np.where(np.arange(n) % 2 == 0, 0.1, 0.3)
    e = rng.normal(0.0, sig)
    recs = [
        stw(T0 + i * 0.1, stw=5.0 + float(e[i]), stw_std=None if i % 10 == 9 else float(sig[i]), sog=6.0)
        for i in range(n)
    ]
    truth = truth_csv({"t": [T0, T0 + 1000.0], "stw": [5.0, 5.0]})
    rows, _ = score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "0")
    s = row(rows, "stw")
    assert s["n"] == n and s["n_sigma"] == n - n // 10  # a null σ is left out of coverage only
    assert s["pct_1sigma"] == pytest.approx(68.27, abs=2.0)
    assert s["pct_2sigma"] == pytest.approx(95.45, abs=1.0)
    assert s["pct_3sigma"] == pytest.approx(99.73, abs=0.3)
    assert s["rmse"] == pytest.approx(math.sqrt((0.1**2 + 0.3**2) / 2), rel=0.05)
    assert abs(s["bias"]) < 0.01
    assert all(abs(s[f"ac{k}"]) < 0.05 for k in (1, 10, 60))  # white


def test_figures_without_samples_or_sigma_are_null():
    f = figures(np.array([]), np.array([]))
    assert (f.n, f.rmse, f.n_sigma, f.within, f.ac) == (0, None, 0, (None,) * 3, (None,) * 3)
    f = figures(np.array([0.1, -0.1]))
    assert f.n_sigma is None and f.ac == (-0.5, None, None)  # shorter than lags 10, 60


def test_angle_error_is_wrapped(mcap, truth_csv, capsys):
    truth = truth_csv({"t": [T0, T0 + 100.0], "heading": [359 * DEG, 359 * DEG]})
    recs = [
        Estimate("nav", "manoeuvre", T0 + i, {"heading": 1 * DEG, "std": {"heading": 3 * DEG}}, kind="manoeuvre")
        for i in range(100)
    ]
    rows, err = score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "0")
    h = row(rows, "heading")
    assert h["unit"] == "rad" and h["n"] == 100
    assert h["bias"] == pytest.approx(2 * DEG, abs=1e-12)  # 1° − 359° = +2°, not −358°
    assert h["max_abs"] == pytest.approx(2 * DEG, abs=1e-12)
    assert h["pct_1sigma"] == 100.0
    assert "lat" in err  # no lat/lon truth: position not scored, and said so


def test_truth_angles_are_interpolated_across_north():
    truth = load_truth(io.StringIO("t,heading\n0,6.248278722\n1,0\n2,0.034906585\n"), "t.csv")  # 358°, 0°, 2°
    t = np.array([0.5, 1.5])
    err, idx = field_errors(truth, "heading", t, np.array([359 * DEG, 0.5 * DEG]), angle=True)
    assert list(idx) == [0, 1]
    assert err == pytest.approx([0.0, -0.5 * DEG], abs=1e-8)  # through 0°, not through 180°


def test_warmup_stale_null_and_outside_truth_are_left_out(mcap, truth_csv, capsys):
    recs = []
    for i in range(100):
        e = 2.0 if i < 30 else 0.1  # converging, then good
        if i in (50, 51, 52):
            recs.append(stw(T0 + i, stw=10.0, stale=True, age=12.0, sog=6.0))
        elif i == 60:
            recs.append(stw(T0 + i, stw=None, sog=6.0))
        else:
            recs.append(stw(T0 + i, stw=5.0 + e, sog=6.0))
    recs.append(stw(T0 + 150, stw=14.0, sog=6.0))  # after the truth ends
    path = mcap(recs)
    truth = truth_csv({"t": [T0, T0 + 100.0], "stw": [5.0, 5.0]})

    rows, _ = score_json(capsys, str(path), "--truth", str(truth), "--warmup", "30")
    s = row(rows, "stw")
    assert s["n"] == 70 - 3 - 1
    assert s["max_abs"] == pytest.approx(0.1) and s["bias"] == pytest.approx(0.1)

    rows, _ = score_json(capsys, str(path), "--truth", str(truth), "--warmup", "0")
    s = row(rows, "stw")
    assert s["n"] == 100 - 3 - 1 and s["max_abs"] == pytest.approx(2.0)


# -- baselines and position ----------------------------------------------------------
def test_sensor_baselines_one_row_per_source_under_their_field(mcap, truth_csv, capsys):
    recs: list[Any] = []
    for i in range(100):
        t = T0 + i
        recs.append(stw(t, stw=5.02, sog=6.0))
        recs.append(Measurement("water_speed", "log1", t, {"stw_long": 5.3}))
        recs.append(Measurement("water_speed", "log2", t + 0.5, {"stw_long": 4.9}))
        recs.append(Measurement("velocity_ground", "gnss1", t, {"sog": 6.1, "cog": 1.0}))
    truth = truth_csv({"t": [T0, T0 + 200.0], "stw": [5.0, 5.0], "sog": [6.0, 6.0]})
    rows, _ = score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "20")

    order = [(r["field"], r["baseline"]) for r in rows]
    i = order.index(("stw", None))
    assert order[i + 1 : i + 3] == [("stw", "/meas/water_speed/log1"), ("stw", "/meas/water_speed/log2")]
    assert row(rows, "stw")["bias"] == pytest.approx(0.02)
    log1, log2 = row(rows, "stw", "/meas/water_speed/log1"), row(rows, "stw", "/meas/water_speed/log2")
    assert log1["baseline_field"] == "stw_long" and log1["unit"] == "m/s"
    assert log1["n"] == 80 and log1["bias"] == pytest.approx(0.3)  # same warm-up: t ≥ first estimate + 20 s
    assert log2["n"] == 80 and log2["bias"] == pytest.approx(-0.1)
    assert log1["n_sigma"] is None and log1["pct_1sigma"] is None  # a sensor has no σ here
    assert row(rows, "sog", "/meas/velocity_ground/gnss1")["rmse"] == pytest.approx(0.1)


def test_draft_baseline_takes_only_its_own_mark(mcap, truth_csv, capsys):
    recs: list[Any] = []
    for i in range(50):
        t = T0 + i
        marks = {"fore_port": {"draft": 10.01, "mean": 10.0, "std": 0.02, "ok": True}}
        recs.append(Estimate("draft", "draft", t, {"marks": marks, "mean_draft": 10.0}, kind="draft"))
        recs.append(Measurement("draft", "can0.DraftMark", t, {"mark": "fore_port", "draft": 10.05, "status": 0}))
        recs.append(Measurement("draft", "can0.DraftMark", t + 0.01, {"mark": "aft_port", "draft": 11.0, "status": 0}))
    truth = truth_csv({"t": [T0, T0 + 60.0], "draft_fore_port": [10.0, 10.0], "draft_fore_port_mean": [10.0, 10.0]})
    rows, _ = score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "0")
    d = row(rows, "marks.fore_port.draft")
    assert d["truth"] == "draft_fore_port" and d["bias"] == pytest.approx(0.01) and d["pct_1sigma"] == 100.0
    b = row(rows, "marks.fore_port.draft", "/meas/draft/can0.DraftMark")
    assert b["n"] == 50 and b["bias"] == pytest.approx(0.05)  # the aft_port messages are not mixed in
    assert row(rows, "marks.fore_port.mean", "/meas/draft/can0.DraftMark")["bias"] == pytest.approx(0.05)


def test_position_error_in_metres_for_estimate_and_gnss(mcap, truth_csv, capsys):
    lat0, lon0 = 60.0, 23.0
    m_per_deg = EARTH_RADIUS * DEG
    d_lat, d_lon = 3.0 / m_per_deg, 4.0 / (m_per_deg * math.cos(lat0 * DEG))  # 3 m north, 4 m east
    recs: list[Any] = []
    for i in range(40):
        t = T0 + i
        recs.append(Estimate("manoeuvre", "manoeuvre", t, {"lat": lat0 + d_lat, "lon": lon0 + d_lon, "u": 5.0}, kind="manoeuvre"))
        recs.append(Measurement("position", "gnss1", t, {"lat": lat0 + 30.0 / m_per_deg, "lon": lon0, "fix_quality": 1}))
    truth = truth_csv({"t": [T0, T0 + 50.0], "lat": [lat0, lat0], "lon": [lon0, lon0], "u": [5.0, 5.0]})
    rows, _ = score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "0")
    p = row(rows, "position")
    assert p["unit"] == "m" and p["n"] == 40
    assert p["rmse"] == pytest.approx(5.0, abs=1e-6) and p["max_abs"] == pytest.approx(5.0, abs=1e-6)
    g = row(rows, "position", "/meas/position/gnss1")
    assert g["rmse"] == pytest.approx(30.0, abs=1e-6) and g["n"] == 40


# -- output ----------------------------------------------------------------------------
def test_json_is_one_document_with_the_same_keys_on_every_row(mcap, truth_csv, capsys):
    recs = [stw(T0 + i, stw=5.1, stw_std=0.2, sog=6.0) for i in range(20)]
    recs += [Measurement("water_speed", "log1", T0 + i, {"stw_long": 5.3}) for i in range(20)]
    truth = truth_csv({"t": [T0, T0 + 30.0], "stw": [5.0, 5.0], "sog": [6.0, 6.0]})
    rows, _ = score_json(capsys, str(mcap(recs)), "--truth", str(truth), "--warmup", "0")
    assert isinstance(rows, list) and len(rows) >= 3
    keys = {
        "estimate", "kind", "field", "truth", "unit", "baseline", "baseline_field", "n", "rmse", "bias",
        "max_abs", "n_sigma", "pct_1sigma", "pct_2sigma", "pct_3sigma", "ac1", "ac10", "ac60",
    }
    assert all(set(r) == keys for r in rows)
    assert row(rows, "stw")["ac60"] is None  # 20 samples: no lag 60


def test_end_to_end_table_through_the_cli(mcap, truth_csv, capsys):
    recs: list[Any] = []
    for i in range(100):
        recs.append(stw(T0 + i, stw=5.1, stw_std=0.2, sog=6.0))
        recs.append(Measurement("water_speed", "log1", T0 + i, {"stw_long": 5.3}))
    truth = truth_csv({"t": [T0, T0 + 100.0], "stw": [5.0, 5.0], "sog": [6.0, 6.0]})
    assert cli(["score", str(mcap(recs)), "--truth", str(truth)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["estimate", "field", "unit", "n", "rmse", "bias", "max", "1sig%", "2sig%", "3sig%", "ac1", "ac10", "ac60"]
    stw_line = next(ln for ln in lines if ln.split()[:2] == ["stw", "stw"])
    assert stw_line.split()[2:7] == ["m/s", "40", "0.1", "0.1", "0.1"]
    assert stw_line.split()[7:10] == ["100.0", "100.0", "100.0"]
    sensor = lines[lines.index(stw_line) + 1]
    assert sensor.startswith(" ") and "vs /meas/water_speed/log1 (stw_long)" in sensor
    assert sensor.split()[-10:-6] == ["40", "0.3", "0.3", "0.3"]
    assert sensor.split()[-6:-3] == ["-", "-", "-"]  # no σ for the sensor


def test_estimate_option_restricts_and_unscorable_kinds_are_named(mcap, truth_csv, capsys):
    recs: list[Any] = []
    for i in range(10):
        recs.append(stw(T0 + i, stw=5.1, sog=6.0))
        recs.append(Estimate("stw_paper", "stw", T0 + i, {"stw": 5.5, "sog": 6.0}, kind="stw"))
        recs.append(Estimate("mystery", "x", T0 + i, {"stw": 1.0}))
    truth = truth_csv({"t": [T0, T0 + 30.0], "stw": [5.0, 5.0], "sog": [6.0, 6.0]})
    path = mcap(recs)
    rows, err = score_json(capsys, str(path), "--truth", str(truth), "--warmup", "0", "--estimate", "stw_paper")
    assert {r["estimate"] for r in rows} == {"stw_paper"}
    assert row(rows, "stw")["bias"] == pytest.approx(0.5)
    rows, err = score_json(capsys, str(path), "--truth", str(truth), "--warmup", "0")
    assert {r["estimate"] for r in rows} == {"stw", "stw_paper"}
    assert "/est/mystery" in err and "kind null" in err and "not scorable" in err
    assert cli(["score", str(path), "--truth", str(truth), "--estimate", "mystery"]) == 2
    assert "kind null" in capsys.readouterr().err
    assert cli(["score", str(path), "--truth", str(truth), "--estimate", "nope"]) == 2
    err = capsys.readouterr().err
    assert "no estimate named nope" in err and "stw_paper" in err


def test_a_closed_pipe_is_one_line_never_a_traceback(mcap, truth_csv):
    recs = [stw(T0 + i, stw=5.1, sog=6.0) for i in range(10)]
    truth = truth_csv({"t": [T0, T0 + 30.0], "stw": [5.0, 5.0]})
    path = mcap(recs)
    r, w = os.pipe()
    os.close(r)  # the reader is gone before edged writes a byte, as after `| head -0`
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "edged.cli", "score", str(path), "--truth", str(truth), "--warmup", "0"],
            stdout=w, stderr=subprocess.PIPE, timeout=60, check=False,
        )
    finally:
        os.close(w)
    err = proc.stderr.decode()
    assert "Traceback" not in err and "BrokenPipe" not in err
    assert "edged score: standard output closed by its reader" in err
    assert proc.returncode == 1


# -- bad input -------------------------------------------------------------------------
def test_missing_and_not_mcap_files(mcap, truth_csv, tmp_path, capsys):
    truth = truth_csv({"t": [T0, T0 + 30.0], "stw": [5.0, 5.0]})
    good = mcap([stw(T0 + i, stw=5.1, sog=6.0) for i in range(10)])
    assert cli(["score", str(tmp_path / "nope.mcap"), "--truth", str(truth)]) == 2
    assert "nope.mcap: no such file" in capsys.readouterr().err
    assert cli(["score", str(good), "--truth", str(tmp_path / "nope.csv")]) == 2
    assert "nope.csv: no such file" in capsys.readouterr().err
    bad = tmp_path / "bad.mcap"
    bad.write_text("hello")
    assert cli(["score", str(bad), "--truth", str(truth)]) == 2
    err = capsys.readouterr().err
    assert "bad.mcap" in err and "MCAP" in err and len(err.strip().splitlines()) == 1
    assert cli(["score", str(good), "--truth", str(good)]) == 2  # an MCAP file given as truth
    assert "not a text file" in capsys.readouterr().err
    assert cli(["score", str(good), "--truth", str(truth), "--warmup", "-1"]) == 2
    assert "--warmup" in capsys.readouterr().err


def test_truth_without_t_or_numbers(mcap, tmp_path, capsys):
    good = mcap([stw(T0 + i, stw=5.1, sog=6.0) for i in range(10)])
    no_t = tmp_path / "no_t.csv"
    no_t.write_text("time,stw\n1,5\n")
    assert cli(["score", str(good), "--truth", str(no_t)]) == 2
    err = capsys.readouterr().err
    assert "no_t.csv: no 't' column" in err and "time, stw" in err
    junk = tmp_path / "junk.csv"
    junk.write_text("t,stw\nabc,5\n1,x\n2\n")
    assert cli(["score", str(good), "--truth", str(junk)]) == 2
    assert "junk.csv: no numeric rows (3 bad rows skipped)" in capsys.readouterr().err


def test_bad_truth_rows_are_counted_and_skipped(mcap, truth_csv, capsys):
    good = mcap([stw(T0 + i, stw=5.1, sog=6.0) for i in range(10)])
    truth = truth_csv({"t": [T0, T0 + 30.0], "stw": [5.0, 5.0]}, extra=["oops,5", f"{T0 + 40},five", "", f"{T0 + 50}"])
    rows, err = score_json(capsys, str(good), "--truth", str(truth), "--warmup", "0")
    assert "truth.csv: 3 bad row(s) skipped" in err
    assert row(rows, "stw")["n"] == 10


def test_truth_table_parsing():
    t = load_truth(io.StringIO("\ufefft , a ,b\n3,30,\n1,10,inf\n\n2,20,nan\n"), "x.csv")
    assert list(t.t) == [1.0, 2.0, 3.0]  # sorted
    assert list(t.columns["a"]) == [10.0, 20.0, 30.0]
    assert np.isnan(t.columns["b"]).all()  # empty, nan and inf: truth unknown
    with pytest.raises(ScoreError, match="empty"):
        load_truth(io.StringIO(""), "e.csv")


def test_no_estimates_no_overlap_and_nothing_after_warmup(mcap, truth_csv, capsys):
    truth = truth_csv({"t": [T0, T0 + 30.0], "stw": [5.0, 5.0]})
    only_meas = mcap([Measurement("water_speed", "log1", T0 + i, {"stw_long": 5.0}) for i in range(5)], name="m.mcap")
    assert cli(["score", str(only_meas), "--truth", str(truth)]) == 2
    assert "m.mcap: no estimates" in capsys.readouterr().err

    later = mcap([stw(T0 + 86400 + i, stw=5.1, sog=6.0) for i in range(10)], name="later.mcap")
    assert cli(["score", str(later), "--truth", str(truth)]) == 2
    err = capsys.readouterr().err
    assert "later.mcap" in err and "truth.csv" in err and "no overlapping time" in err

    short = mcap([stw(T0 + i, stw=5.1, sog=6.0) for i in range(10)], name="short.mcap")
    assert cli(["score", str(short), "--truth", str(truth)]) == 2  # all inside the 60 s warm-up
    assert "nothing left to score after the 60 s warm-up" in capsys.readouterr().err

    unrelated = truth_csv({"t": [T0, T0 + 30.0], "depth": [20.0, 20.0]}, name="depth.csv")
    assert cli(["score", str(short), "--truth", str(unrelated), "--warmup", "0"]) == 2
    assert "depth.csv: none of the columns the estimates are scored against" in capsys.readouterr().err


def test_an_unfinished_recording_is_scored_from_what_is_readable(mcap, truth_csv, tmp_path, capsys):
    recs = [stw(T0 + i * 0.1, stw=5.1, sog=6.0, mode="vector", distance=float(i)) for i in range(3000)]
    path = mcap(recs, chunk_kib=4, compression="none")
    cut = tmp_path / "cut.mcap"
    data = path.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    truth = truth_csv({"t": [T0, T0 + 400.0], "stw": [5.0, 5.0]})
    rows, err = score_json(capsys, str(cut), "--truth", str(truth), "--warmup", "0")
    assert "unfinished recording" in err
    assert 0 < row(rows, "stw")["n"] < 3000
