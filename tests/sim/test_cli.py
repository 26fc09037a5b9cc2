"""`edged sim`: the files, exit codes, determinism, and the faults it says it injected."""

from __future__ import annotations

import json
import re
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from edged.cli import build_parser
from edged_sim.cli import main
from edged_sim.dbc import DRAFT_IDS
from edged_sim.truth import columns

FILES = ("nmea.log", "can.log", "truth.csv", "meta.json")


def _sim(tmp: Path, *argv: str) -> int:
    return main(build_parser().parse_args(["sim", *argv, "--out", str(tmp)]))


def test_unknown_scenario_exits_2_with_the_list(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert _sim(tmp_path / "x", "no-such-scenario") == 2
    err = capsys.readouterr().err
    assert "no-such-scenario" in err and "manoeuvre-williamson" in err and "draft-squat" in err
    assert not (tmp_path / "x").exists()


def test_bad_duration_exits_2(tmp_path: Path) -> None:
    assert _sim(tmp_path, "faults", "--duration", "-5") == 2


def test_writes_the_four_files(tmp_path: Path) -> None:
    assert _sim(tmp_path, "manoeuvre-williamson", "--duration", "20", "--seed", "4") == 0
    assert all((tmp_path / f).exists() for f in FILES)
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["scenario"] == "manoeuvre-williamson" and meta["seed"] == 4 and meta["duration_s"] == 20
    assert meta["ship"]["length"] == 120.0 and meta["start_time"] == 1732350000
    header = (tmp_path / "truth.csv").read_text().splitlines()[0].split(",")
    assert tuple(header) == columns()
    truth = np.loadtxt(tmp_path / "truth.csv", delimiter=",", skiprows=1)
    assert truth.shape == (200, len(columns()))  # 10 Hz for 20 s
    assert meta["files"]["nmea.log"] == len((tmp_path / "nmea.log").read_text().splitlines())


@pytest.fixture(scope="module")
def faults_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    base = tmp_path_factory.mktemp("faults")
    for name, seed in (("a", "11"), ("b", "11"), ("c", "12")):
        assert main(build_parser().parse_args(["sim", "faults", "--out", str(base / name), "--duration", "120", "--seed", seed])) == 0
    return base / "a", base / "b", base / "c"


def test_same_seed_same_bytes(faults_runs: tuple[Path, Path, Path]) -> None:
    a, b, c = faults_runs
    for f in FILES:
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    assert (a / "nmea.log").read_bytes() != (c / "nmea.log").read_bytes()


def _xor(text: str) -> int:
    x = 0
    for ch in text.encode():
        x ^= ch
    return x


def test_faults_in_the_files_are_those_meta_reports(faults_runs: tuple[Path, Path, Path]) -> None:
    out = faults_runs[0]
    meta = json.loads((out / "meta.json").read_text())
    injected = meta["faults"]["injected"]
    found = Counter()
    for line in (out / "nmea.log").read_text(encoding="ascii").splitlines():
        if not line.startswith("\\c:"):
            found["garbage"] += 1
            continue
        sentence = line[line.index("\\", 1) + 1:]
        body, cs = sentence[1:].split("*")
        if int(cs, 16) != _xor(body):
            found["bad_checksum"] += 1
        elif body[2:5] == "GGA" and float(body.split(",")[2][:2]) > 90:
            found["impossible_value"] += 1
    lost = Counter()
    last: dict[int, int] = {}
    dlc = {**{i: 4 for i in DRAFT_IDS.values()}, 0x320: 6, 0x321: 8, 0x322: 6}
    truncated_marks = 0
    for line in (out / "can.log").read_text().splitlines():
        ident, data = line.split()[2].split("#")
        if len(ident) == 3:
            fid = int(ident, 16)
            if len(data) != 2 * dlc[fid]:
                found["bad_length"] += 1
                truncated_marks += fid in DRAFT_IDS.values()
                continue
            if fid not in DRAFT_IDS.values():
                continue
            counter = int(data[6:8], 16)
            if fid in last:
                lost[fid] += (counter - last[fid] - 1) % 256
            last[fid] = counter
    assert {k: v for k, v in found.items() if v} == injected
    assert all(injected.get(k, 0) > 0 for k in ("bad_checksum", "garbage", "impossible_value"))
    dropouts = meta["faults"]["dropouts"]
    # A gap in a mark's counter is a lost sample or a truncated frame of that mark.
    assert sum(lost.values()) == sum(v for k, v in dropouts.items() if k.startswith("draft.")) + truncated_marks
    assert meta["faults"]["position_jumps"][0]["north_m"] == 150.0
    assert re.match(r"^\d{4}-\d\d-\d\dT", meta["start_time_iso"])
