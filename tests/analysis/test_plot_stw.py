"""`edged plot` for speed-through-water estimates: the paper's figures (DESIGN §6 est/stw).

The data preparation (`edged_analysis.plotdata` and `stwdata`: series per stw instance,
error against truth, its autocorrelation) is tested without matplotlib; the PNG with
it: the `plot` extra is part of the test environment (`make test` installs it), so a
missing matplotlib fails those tests rather than hiding them. Recordings are written
with the project's recorder (conftest `make_rig`), truth tables by hand, errors seeded
so that every figure is known in advance.
"""

from __future__ import annotations

import argparse
import math
import random
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from edged.records import Estimate, Measurement
from edged_analysis.commands import plot
from edged_analysis.figures import autocorrelation
from edged_analysis.plotdata import collect
from edged_analysis.stwdata import error_autocorrelation, stw_error, white_band
from edged_analysis.truth import ScoreError, read_truth

T0 = 1_732_350_000.0
N = 400  # 1 Hz estimates


def true_stw(i: float) -> float:
    return 5.0 + 0.5 * math.sin(i / 60.0)


def stw_estimates(name: str, seed: int, n: int = N, sigma: float = 0.1) -> list[Estimate]:
    """`n` stw estimates at 1 Hz: truth + seeded white N(0, sigma), the log 0.3 m/s
    high (null every 5th second), a following current of 0.2 m/s."""
    rnd = random.Random(seed)
    out = []
    for i in range(n):
        out.append(
            Estimate(
                name,
                name,
                T0 + i,
                {
                    "stw": true_stw(i) + rnd.gauss(0.0, sigma),
                    "stw_std": sigma,
                    "sog": true_stw(i) + 0.2,
                    "current": 0.2,
                    "distance": 5.0 * i,
                    "dvl_stw": None if i % 5 == 0 else true_stw(i) + 0.3,
                    "stw_long": None,
                    "stw_trans": None,
                    "mode": "paper" if name.endswith("paper") else "vector",
                    "current_set": 1.0,
                    "current_along": 0.2,
                    "dvl_bias": 0.3,
                    "dvl_scale": 1.0,
                    "dvl_std": {"bias": 0.01, "scale": 0.001},
                },
                kind="stw",
            )
        )
    return out


@pytest.fixture
def voyage(mcap) -> Path:
    """Two stw instances (est/stw, est/stw_paper), a manoeuvre estimate and GNSS SOG."""
    recs: list[Any] = stw_estimates("stw", seed=1) + stw_estimates("stw_paper", seed=2, sigma=0.2)
    recs += [Estimate("manoeuvre", "manoeuvre", T0 + i, {"lat": 60.0, "lon": 23.0, "u": 5.0}, kind="manoeuvre") for i in range(10)]
    recs += [Measurement("velocity_ground", "gnss1", T0 + i, {"sog": 5.2, "cog": 1.0}) for i in range(10)]
    return mcap(recs)


def write_truth(tmp_path: Path, first: int = 0, last: int = N - 1, name: str = "truth.csv", step: float = 1.0) -> Path:
    """The simulator's layout (t, t_rel, ..., stw, ...) from second `first` to `last`."""
    rows = ["t,t_rel,sog,stw,current_along"]
    i = float(first)
    while i <= last:
        rows.append(f"{T0 + i!r},{i!r},{true_stw(i) + 0.2!r},{true_stw(i)!r},0.2")
        i += step
    path = tmp_path / name
    path.write_text("\n".join(rows) + "\n")
    return path


def run_plot(capsys, file: Path, out: Path, truth: Path | str | None = None) -> tuple[int, str]:
    rc = plot.main(argparse.Namespace(file=str(file), output=str(out), truth=None if truth is None else str(truth)))
    return rc, capsys.readouterr().err


# -- series -------------------------------------------------------------------------
def test_each_stw_instance_is_one_series_in_si_with_nan_for_null(voyage):
    data = collect(voyage)
    assert list(data.stw) == ["stw", "stw_paper"]  # the manoeuvre estimate is not an stw one
    s = data.stw["stw"]
    expected = stw_estimates("stw", seed=1)
    assert s.t.tolist() == [e.t for e in expected]
    assert s.stw.tolist() == [e.values["stw"] for e in expected]  # m/s, not knots
    assert s.stw_std.tolist() == [0.1] * N
    assert np.all(s.values["current_along"] == 0.2)
    assert np.all(s.values["sog"] == np.array([true_stw(i) + 0.2 for i in range(N)]))
    dvl = s.values["dvl_stw"]
    assert np.isnan(dvl[::5]).all() and np.isfinite(dvl[1::5]).all()
    assert dvl[1] == true_stw(1) + 0.3
    assert not s.stale.any()
    assert data.stw["stw_paper"].stw.tolist() == [e.values["stw"] for e in stw_estimates("stw_paper", seed=2, sigma=0.2)]


def test_an_stw_estimate_without_a_kind_on_est_stw_is_still_shown(mcap):
    # Older recordings and tools wrote /est/stw with no kind (schema edged.est).
    path = mcap([Estimate("stw", "stw", T0 + i, {"stw": 5.0, "stw_std": 0.1, "sog": 5.1}) for i in range(3)]
                + [Estimate("other", "other", T0, {"stw": 9.0})])
    data = collect(path)
    assert list(data.stw) == ["stw"]
    assert data.stw["stw"].stw.tolist() == [5.0] * 3
    assert np.isnan(data.stw["stw"].values["dvl_stw"]).all()


def test_an_stw_estimate_with_fields_null_or_missing_keeps_its_times(mcap):
    path = mcap([
        Estimate("stw", "stw", T0, {"stw": 5.0, "stw_std": None}, kind="stw"),
        Estimate("stw", "stw", T0 + 1, {"stw": None, "stw_std": 0.1, "sog": float("nan")}, kind="stw"),
    ])
    s = collect(path).stw["stw"]
    assert s.t.tolist() == [T0, T0 + 1]
    assert s.stw[0] == 5.0 and np.isnan(s.stw[1])
    assert np.isnan(s.stw_std[0]) and s.stw_std[1] == 0.1
    assert not s.has("sog") and s.has("stw")


# -- error against truth ----------------------------------------------------------------
def test_error_is_the_estimate_minus_truth_at_matching_times_and_left_out_outside_the_truth(voyage, tmp_path):
    truth = read_truth(write_truth(tmp_path, first=50, last=300))
    s = collect(voyage).stw["stw"]
    e = stw_error(s, truth)
    assert e.n == 251
    assert e.t.tolist() == [T0 + i for i in range(50, 301)]
    want = np.array([s.stw[i] - true_stw(i) for i in range(50, 301)])
    assert np.allclose(e.err, want, rtol=0, atol=1e-12)
    assert np.all(e.std == 0.1)
    # Seeded N(0, 0.1): about 68 / 95 / 99.7 % inside ±1/2/3σ.
    w1, w2, w3 = e.within()
    assert 60 < w1 < 76 and 91 < w2 < 99 and w3 > 98.5
    assert e.rmse == pytest.approx(0.1, rel=0.15)


def test_error_against_a_coarser_truth_is_interpolated_linearly(voyage, tmp_path):
    truth = read_truth(write_truth(tmp_path, first=0, last=N - 1, step=2.0))
    s = collect(voyage).stw["stw"]
    e = stw_error(s, truth)
    i = 101  # between truth rows at 100 and 102
    k = int(np.flatnonzero(e.t == T0 + i)[0])
    assert e.err[k] == pytest.approx(s.stw[i] - 0.5 * (true_stw(100) + true_stw(102)), abs=1e-12)


def test_error_without_any_overlapping_truth_is_empty(voyage, tmp_path):
    truth_path = tmp_path / "later.csv"
    truth_path.write_text(f"t,stw\n{T0 + 10_000!r},5.0\n{T0 + 10_001!r},5.0\n")
    e = stw_error(collect(voyage).stw["stw"], read_truth(truth_path))
    assert e.n == 0


# -- autocorrelation ------------------------------------------------------------------------
def test_autocorrelation_is_one_at_lag_zero_and_the_correlogram_of_score():
    rng = np.random.default_rng(11)
    x = rng.normal(size=500)
    acf = error_autocorrelation(x, 120)
    assert acf.size == 121 and acf[0] == 1.0
    for k in (1, 10, 60, 120):
        assert acf[k] == autocorrelation(x, k)  # the figure `edged score` prints at lags 1, 10, 60
    d = x - x.mean()
    assert acf[7] == pytest.approx(float(d[:-7] @ d[7:]) / float(d @ d), rel=1e-12)


def test_a_white_seeded_error_stays_inside_the_band_and_a_correlated_one_does_not():
    rng = np.random.default_rng(2024)
    white = rng.normal(0.0, 0.1, size=2000)
    acf = error_autocorrelation(white, 120)
    band = white_band(white.size)
    assert band == pytest.approx(1.96 / math.sqrt(2000))
    inside = np.abs(acf[1:]) <= band
    assert inside.mean() >= 0.9  # ≈ 95 % for white noise
    assert np.abs(acf[1:]).max() < 2 * band
    # A random walk-like error (AR(1), φ = 0.9): far outside at short lags.
    red = np.empty_like(white)
    red[0] = white[0]
    for i in range(1, red.size):
        red[i] = 0.9 * red[i - 1] + white[i]
    acf_red = error_autocorrelation(red, 120)
    assert acf_red[1] == pytest.approx(0.9, abs=0.05)
    assert (np.abs(acf_red[1:11]) > band).all()


def test_autocorrelation_of_a_short_or_constant_error():
    assert error_autocorrelation(np.array([0.1, -0.2, 0.3, 0.0]), 120).size == 4  # lags 0..3 only
    assert error_autocorrelation(np.full(50, 0.2), 10).size == 0  # nothing to correlate
    assert error_autocorrelation(np.array([0.1]), 10).size == 0


# -- the truth file ---------------------------------------------------------------------------
def test_read_truth_names_the_file_when_it_is_missing_or_lacks_t_or_stw(tmp_path):
    with pytest.raises(ScoreError, match=r"nope\.csv: no such file"):
        read_truth(tmp_path / "nope.csv")
    no_stw = tmp_path / "no_stw.csv"
    no_stw.write_text("t,sog\n1.0,5.0\n")
    with pytest.raises(ScoreError, match=r"no_stw\.csv: no 'stw' column"):
        read_truth(no_stw)
    no_t = tmp_path / "no_t.csv"
    no_t.write_text("time,stw\n1.0,5.0\n")
    with pytest.raises(ScoreError, match=r"no_t\.csv: no 't' column"):
        read_truth(no_t)


def bad_truth(what: str, folder: Path) -> Path:
    if what == "missing":
        return folder / "missing.csv"
    if what == "directory":
        return folder
    path = folder / f"{what}.csv"
    path.write_text({"no-stw": "t,sog\n1,2\n", "no-t": "time,stw\n1,2\n", "empty": ""}[what])
    return path


@pytest.mark.parametrize(
    "what, said",
    [
        ("missing", "missing.csv: no such file"),
        ("no-stw", "no-stw.csv: no 'stw' column"),
        ("no-t", "no-t.csv: no 't' column"),
        ("empty", "empty.csv: empty truth table"),
        ("directory", "Is a directory"),
    ],
)
def test_a_bad_truth_file_is_bad_usage_with_one_message_naming_it(voyage, tmp_path, capsys, monkeypatch, what, said):
    # Checked before anything is drawn, so this holds with or without matplotlib.
    monkeypatch.setattr(plot, "_have_matplotlib", lambda: True)
    out = tmp_path / "r.png"
    rc, err = run_plot(capsys, voyage, out, bad_truth(what, tmp_path))
    assert rc == 2
    assert said in err and err.startswith("edged: ") and err.count("\n") == 1
    assert "Traceback" not in err
    assert not out.exists()


def test_without_matplotlib_the_truth_option_changes_nothing(voyage, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(plot, "_have_matplotlib", lambda: False)
    rc, err = run_plot(capsys, voyage, tmp_path / "r.png", write_truth(tmp_path))
    assert rc == 1 and "pip install 'edged[plot]'" in err


# -- the picture (matplotlib: the `plot` extra) ------------------------------------------------
def test_plot_with_truth_writes_the_stw_error_and_autocorrelation_panels(voyage, tmp_path, capsys):
    out = tmp_path / "stw.png"
    rc, err = run_plot(capsys, voyage, out, write_truth(tmp_path, first=20, last=380))
    assert rc == 0, err
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    wrote = err.strip().split(": ", 1)[1].split(", ")
    for name in ("stw", "stw_paper"):
        assert {f"stw {name}", f"error {name}", f"autocorrelation {name}"} <= set(wrote)
    assert "speed" in wrote


def test_plot_without_truth_has_the_stw_panel_only(voyage, tmp_path, capsys):
    out = tmp_path / "stw.png"
    rc, err = run_plot(capsys, voyage, out)
    assert rc == 0, err
    assert out.stat().st_size > 0
    assert "stw stw" in err and "stw stw_paper" in err and "error" not in err and "autocorrelation" not in err


def test_plot_with_truth_that_misses_the_recording_says_so_and_still_draws(voyage, mcap, tmp_path, capsys):
    later = tmp_path / "later.csv"
    later.write_text(f"t,stw\n{T0 + 10_000!r},5.0\n{T0 + 10_001!r},5.0\n")
    rc, err = run_plot(capsys, voyage, tmp_path / "a.png", later)
    assert rc == 0
    assert "later.csv: no truth at the times of est/stw" in err and "error stw" not in err
    no_stw = mcap([Measurement("velocity_ground", "gnss1", T0 + i, {"sog": 5.2, "cog": 1.0}) for i in range(5)], name="gnss.mcap")
    rc, err = run_plot(capsys, no_stw, tmp_path / "b.png", write_truth(tmp_path))
    assert rc == 0
    assert "no estimate of kind stw" in err and "--truth" in err


def test_cli_plot_takes_the_truth_option(voyage, tmp_path, capsys):
    from edged.cli import main as cli

    out = tmp_path / "cli.png"
    assert cli(["plot", str(voyage), "--truth", str(write_truth(tmp_path)), "-o", str(out)]) == 0
    assert "error stw" in capsys.readouterr().err and out.stat().st_size > 0
    assert cli(["plot", str(voyage), "--truth", str(tmp_path / "nope.csv"), "-o", str(out)]) == 2
