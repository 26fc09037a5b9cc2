"""The STW estimator on the simulator's seed-000 scenarios, end to end through the CLI.

`edged sim` → `edged replay` (the default `vector` instance and a `paper` one) →
`edged score`: the ordering the issue asks for, with margins, on one seed each of the
following and the rotating cross current (3 hours, as the issue asks; docs/estimators.md gives
the table over 15 seeds). What a crew relies on: the estimate is well under the log's error
and under the naive "SOG − latest forecast", `vector` beats `paper` in a cross current,
its σ covers the error, and the log's offset is found within its σ.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest

from edged.cli import main as cli

DURATION = 10800
SEED = 6
CONFIG = """
[estimators.stw]
type = "stw"

[estimators.stw_paper]
type = "stw"
mode = "paper"
"""


def _cli(*args: str) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = cli(list(args))
    return rc, out.getvalue() + err.getvalue()


@pytest.fixture(scope="module", params=["stw-astern-current", "stw-cross-current"])
def scored(request, tmp_path_factory) -> tuple[str, dict[str, float], dict]:
    d: Path = tmp_path_factory.mktemp(request.param)
    rc, msg = _cli("sim", request.param, "--out", str(d), "--duration", str(DURATION), "--seed", str(SEED))
    assert rc == 0, msg
    (d / "stw.toml").write_text(CONFIG)
    rec = d / "run.mcap"
    rc, msg = _cli("replay", "-c", str(d / "stw.toml"), str(d / "nmea.log"), str(d / "can.log"),
                   "--no-zenoh", "--no-progress", "--record", str(rec))
    assert rc == 0, msg
    rc, text = _cli("score", str(rec), "--truth", str(d / "truth.csv"), "--warmup", "1200", "--json")
    assert rc == 0, text
    rows = json.loads(text[text.index("["):])
    rmse: dict[str, float] = {}
    for r in rows:
        if r["field"] != "stw":
            continue
        b = r["baseline"]
        key = r["estimate"] if not b else ("naive" if "naive" in b else "dvl" if "water_speed" in b else b)
        rmse.setdefault(key, r["rmse"])
        if not b and r["estimate"] == "stw":
            rmse["within_3sigma"] = r["pct_3sigma"]
    from mcap.reader import make_reader

    last = None
    with rec.open("rb") as f:
        for _, ch, msg in make_reader(f).iter_messages(topics=["/est/stw"]):
            last = json.loads(msg.data)
    return request.param, rmse, last


def test_stw_is_well_under_the_log_and_the_naive_estimate(scored):
    scenario, rmse, _ = scored
    assert rmse["stw"] < 0.8 * rmse["dvl"], rmse
    if scenario == "stw-astern-current":
        assert rmse["stw"] <= 0.85 * rmse["naive"], rmse
    else:
        assert rmse["stw"] <= 1.0 * rmse["naive"], rmse


def test_vector_beats_paper_in_a_cross_current(scored):
    scenario, rmse, _ = scored
    if scenario == "stw-cross-current":
        assert rmse["stw"] < 0.5 * rmse["stw_paper"], rmse


def test_sigma_covers_the_error(scored):
    _, rmse, _ = scored
    assert rmse["within_3sigma"] >= 98.0, rmse


def test_log_offset_found_within_its_sigma(scored):
    _, _, last = scored
    assert last["dvl_bias"] == pytest.approx(0.3, abs=3 * last["dvl_std"]["bias"])
    assert last["dvl_std"]["bias"] < 0.15
