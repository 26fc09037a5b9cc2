"""`edged sim --waves`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from edged.cli import build_parser
from edged_sim.cli import main
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
