"""`edged inspect` and `export` on recordings, through the real CLI (`plot`:
`tests/analysis/test_plot.py`)."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import pytest

from edged.cli import main as cli
from edged.records import Estimate
from mcap_rig import voyage_with_a_log_gap


@pytest.fixture
def recording(tmp_path) -> Path:
    return voyage_with_a_log_gap(tmp_path / "voyage.mcap")


def test_inspect_lists_channels_counts_rates_span_and_gaps(recording, capsys):
    assert cli(["inspect", str(recording)]) == 0
    out = capsys.readouterr().out
    assert "finished, summary present" in out
    assert "vessel    ship1" in out
    lines = {ln.split()[0]: ln.split() for ln in out.splitlines() if ln.startswith("/")}
    assert lines["/raw/can/can0"][1:3] == ["edged.raw.can", "300"]
    assert float(lines["/raw/nmea0183/gnss1"][3]) == pytest.approx(49 / 4.9, rel=1e-6)  # 50 in 4.9 s
    log = lines["/meas/water_speed/log1"]
    assert log[2] == "4" and float(log[5]) == pytest.approx(30.0)  # largest gap 30 s
    assert "span      2024-11-23T08:20:00.000Z .. 2024-11-23T08:20:32.000Z" in out


def test_inspect_says_a_file_is_unfinished(recording, tmp_path, capsys):
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(recording.read_bytes()[:-2000])
    assert cli(["inspect", str(cut)]) == 0
    out = capsys.readouterr().out
    assert "UNFINISHED" in out and "edged recover" in out


def test_inspect_and_export_reject_bad_files(tmp_path, capsys):
    assert cli(["inspect", str(tmp_path / "nope.mcap")]) == 2
    bad = tmp_path / "bad.mcap"
    bad.write_text("hello")
    assert cli(["inspect", str(bad)]) == 1
    assert cli(["export", str(bad), "--topic", "/health"]) == 1
    assert "MCAP" in capsys.readouterr().err


def test_export_csv_has_flat_columns(recording, tmp_path):
    out = tmp_path / "draft.csv"
    assert cli(["export", str(recording), "--topic", "/est/draft", "-o", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 50
    assert {"log_time", "t", "marks.fore.mean", "marks.aft.mean", "mean_draft", "trim"} <= set(rows[0])
    assert float(rows[0]["marks.aft.mean"]) == 8.5
    assert float(rows[0]["t"]) == 1_732_350_000.0


def test_export_jsonl_to_stdout(recording, capsys):
    assert cli(["export", str(recording), "--topic", "/location/gnss1", "--format", "jsonl"]) == 0
    rows = [json.loads(ln) for ln in capsys.readouterr().out.splitlines()]
    assert len(rows) == 50
    assert {"timestamp.sec", "timestamp.nsec", "latitude", "position_covariance"} <= set(rows[0])
    assert json.loads(rows[0]["position_covariance"]) == [0.0] * 9  # lists stay one cell


def test_export_unknown_topic_names_the_known_ones(recording, tmp_path, capsys):
    out = tmp_path / "x.csv"
    assert cli(["export", str(recording), "--topic", "/est/nothing", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "/est/nothing" in err and "/est/stw" in err
    assert not out.exists()


def test_export_keeps_null_and_full_float_precision(make_rig, tmp_path, capsys):
    path = tmp_path / "p.mcap"
    rig = make_rig(path=str(path))
    rig.open()
    rig.rec.write([Estimate("stw", "stw", 1.0 / 3.0, {"stw": math.pi, "dvl_stw": None})])
    rig.close()
    assert cli(["export", str(path), "--topic", "/est/stw"]) == 0
    (row,) = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert float(row["stw"]) == math.pi and float(row["t"]) == 1.0 / 3.0 and row["dvl_stw"] == ""
