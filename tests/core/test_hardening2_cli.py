"""Hardening, second round (issue 32), the command line: a flag a user mistypes gets
one line that names it and says what it takes, never a traceback or a link."""

from __future__ import annotations

from pathlib import Path

import pytest

from edged.cli import build_parser, main


def _parse_exit(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(argv)
    return int(e.value.code), capsys.readouterr().err


@pytest.mark.parametrize("seed", ["-1", "-4294967296", "4294967296", "99999999999999999999", "1.5", "one", ""])
def test_a_seed_numpy_cannot_take_is_refused_at_parsing(seed, capsys):
    code, err = _parse_exit(["sim", "draft-harbour", "--out", "x", f"--seed={seed}"], capsys)
    assert code == 2
    assert "--seed" in err and "0 to 4294967295" in err and "Traceback" not in err


@pytest.mark.parametrize("seed", ["0", "7", "4294967295"])
def test_seeds_in_range_pass(seed):
    assert build_parser().parse_args(["sim", "draft-harbour", "--out", "x", "--seed", seed]).seed == int(seed)


@pytest.mark.parametrize("vid", ["a/b", "a b", "*", "ä", "a$b", ""])
def test_a_vessel_id_that_is_no_key_segment_says_why(vid, tmp_path: Path, capsys):
    log = tmp_path / "a.log"
    log.write_text("")
    rc = main(["replay", "--no-zenoh", "--no-progress", "--vessel-id", vid, str(log)])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "--vessel-id" in err and "Zenoh key segment" in err
    assert "pydantic" not in err and "http" not in err
