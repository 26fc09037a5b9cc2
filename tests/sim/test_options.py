"""`edged sim --waves`, the windowed sensor faults (offsets, forced values, dropout
spells) and the `draft-faulty-mark` scenario built from them."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from edged.cli import build_parser
from edged_sim.cli import main
from edged_sim.dbc import DRAFT_IDS
from edged_sim.run import Simulation
from edged_sim.scenarios import FAULT_WINDOWS, SCENARIOS
from edged_sim.waves import JonswapWaves, RegularWaves, parse_waves


def _sim(out: Path, *argv: str) -> int:
    return main(build_parser().parse_args(["sim", *argv, "--out", str(out)]))


def test_parse_waves_forms() -> None:
    assert parse_waves("regular:0.4,12", 150.0) == RegularWaves(0.4, 12.0, from_deg=150.0)
    assert parse_waves("regular:0.5,8,30") == RegularWaves(0.5, 8.0, from_deg=30.0)
    assert parse_waves(" JONSWAP:1.13, 12 ", 270.0) == JonswapWaves(1.13, 12.0, from_deg=270.0)
    assert parse_waves("jonswap:2,9,370") == JonswapWaves(2.0, 9.0, from_deg=10.0)


@pytest.mark.parametrize("spec", ["", "regular", "regular:", "regular:0.4", "regular:0.4,12,3,4", "calm:1,2",
                                  "jonswap:a,12", "jonswap:1,nan", "regular:-1,12", "regular:0.4,0", "0.4,12"])
def test_parse_waves_refuses(spec: str) -> None:
    with pytest.raises(ValueError):
        parse_waves(spec)


def test_bad_waves_exits_2_naming_the_option(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert _sim(tmp_path / "x", "draft-harbour", "--duration", "1", "--waves", "regular:0.4") == 2
    err = capsys.readouterr().err
    assert "--waves" in err and "regular:0.4" in err
    assert not (tmp_path / "x").exists()


def test_waves_override_is_used_and_recorded(tmp_path: Path) -> None:
    assert _sim(tmp_path / "a", "draft-harbour", "--duration", "2", "--seed", "5") == 0
    assert _sim(tmp_path / "b", "draft-harbour", "--duration", "2", "--seed", "5", "--waves", "jonswap:1.13,12") == 0
    a, b = (json.loads((tmp_path / d / "meta.json").read_text()) for d in "ab")
    assert a["waves"] == {"type": "RegularWaves", "amplitude": 0.4, "period": 12.0, "from_deg": 150.0}
    assert a["overrides"] == {}
    assert b["waves"]["type"] == "JonswapWaves" and b["waves"]["hs"] == 1.13 and b["waves"]["tp"] == 12.0
    assert b["waves"]["from_deg"] == 150.0  # the scenario's direction
    assert b["overrides"] == {"waves": "jonswap:1.13,12"}
    assert (tmp_path / "a" / "truth.csv").read_bytes() != (tmp_path / "b" / "truth.csv").read_bytes()


def _frames(sim: Simulation, fid: int) -> list[tuple[int, bytes]]:
    return [(int(t), data) for chunk in sim.chunks(1.0)
            for t, (i, ext, data) in zip(chunk.can.t_us.tolist(), chunk.can.payload) if i == fid and not ext]


def test_windowed_faults_change_only_their_mark_and_window() -> None:
    """Each fault of a mark over its own window of a 3-s run: everything else, the
    other marks and this mark outside the windows, is byte for byte the clean run's."""
    base = replace(SCENARIOS["draft-harbour"], duration_s=3.0)

    def faulty(s):
        if s.mark != "fore_port":
            return s
        return replace(s, outages=((0.5, 0.8),), offsets=((1.0, 1.3, "draft", 1.0),),
                       forced=((1.5, 1.8, "status", 1.0), (2.0, 2.3, "draft", 45.0)),
                       dropout_spells=((2.5, 2.8, 0.5),))

    bad = replace(base, sensors=tuple(faulty(s) for s in base.sensors))
    fid = DRAFT_IDS["fore_port"]
    clean = dict(_frames(Simulation(base, seed=2), fid))
    sim = Simulation(bad, seed=2)
    got = _frames(sim, fid)
    t0 = base.start_epoch * 1_000_000

    def inside(t: int, a: float, b: float) -> bool:
        return a * 1e6 <= t - t0 < b * 1e6

    for t, data in got:
        draft, status, counter = int.from_bytes(data[:2], "little"), data[2], data[3]
        ref = int.from_bytes(clean[t][:2], "little")
        assert counter == clean[t][3]  # the counter follows the sampling grid
        if inside(t, 1.0, 1.3):
            assert draft - ref == 1000 and status == 0
        elif inside(t, 1.5, 1.8):
            assert draft == ref and status == 1
        elif inside(t, 2.0, 2.3):
            assert draft == 45000 and status == 0
        else:
            assert data == clean[t]
    times = {t for t, _ in got}
    assert not any(inside(t, 0.5, 0.8) for t in times)  # silent
    lost = [t for t in clean if inside(t, 2.5, 2.8) and t not in times]
    assert 5 <= len(lost) <= 25  # about half of 30 frames
    assert len(clean) - len(got) == 30 + len(lost) == sim.dropped["draft.fore_port"]
    for name in ("fore_stbd", "aft_stbd"):  # the other marks: untouched
        assert _frames(Simulation(base, seed=2), DRAFT_IDS[name]) == _frames(Simulation(bad, seed=2), DRAFT_IDS[name])
    kinds = [w["kind"] for w in sim.meta()["faults"]["windows"]]
    assert kinds == ["outage", "offset", "forced", "forced", "dropout"]


def test_draft_faulty_mark_is_draft_harbour_with_five_faults(tmp_path: Path) -> None:
    harbour, faulty = SCENARIOS["draft-harbour"], SCENARIOS["draft-faulty-mark"]
    assert faulty.duration_s == 1200.0
    assert (faulty.ship, faulty.loading, faulty.waves, faulty.water) == (harbour.ship, harbour.loading, harbour.waves,
                                                                         harbour.water)
    changed = [s.name for s, h in zip(faulty.sensors, harbour.sensors) if s != h]
    assert changed == ["draft.fore_port"]
    spans = sorted(FAULT_WINDOWS.values())
    assert all(b - a == 120.0 for a, b in spans) and all(b0 < a1 for (_, b0), (a1, _) in zip(spans, spans[1:]))
    assert _sim(tmp_path, "draft-faulty-mark", "--duration", "1", "--seed", "3") == 0
    windows = json.loads((tmp_path / "meta.json").read_text())["faults"]["windows"]
    assert [(w["kind"], w.get("field"), w.get("value"), w["start_s"], w["end_s"]) for w in windows] == [
        ("outage", None, None, *FAULT_WINDOWS["silence"]),
        ("offset", "draft", 1.0, *FAULT_WINDOWS["offset"]),
        ("forced", "status", 1.0, *FAULT_WINDOWS["status"]),
        ("forced", "draft", 45.0, *FAULT_WINDOWS["range"]),
        ("dropout", None, None, *FAULT_WINDOWS["gaps"]),
    ]
    assert {w["sensor"] for w in windows} == {"draft.fore_port"}
    assert np.isclose(windows[-1]["probability"], 0.5)
