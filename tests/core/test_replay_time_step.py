"""Hardening, second round (issue 32): a log whose time steps back mid-file.

An hour back at half-way gave 54,600 inputs counted `late`, no estimates for the second
half, exit 0 and "300.0 s of data", nothing else. Now the replay says where and how
far the time stepped back and how many records reached no estimator (exit 0: real logs
do it, and it is the log's doing)."""

from __future__ import annotations

from pathlib import Path

import pytest
from nmea_text import sentence

from edged.cli import main


def _hms(sec: int) -> str:
    return f"{sec // 3600:02d}{sec % 3600 // 60:02d}{sec % 60:02d}.00"


def _log(path: Path, first: int, second: int, back: int) -> Path:
    """`first` s of 1 Hz RMC from 12:00:00, then `second` s starting `back` s earlier
    than where the first part ended."""
    lines = [sentence(f"GPRMC,{_hms(12 * 3600 + k)},A,5400.000,N,01000.000,E,0.0,0.0,041226,,,A") for k in range(first)]
    start = 12 * 3600 + first - back
    lines += [sentence(f"GPRMC,{_hms(start + k)},A,5400.000,N,01000.000,E,0.0,0.0,041226,,,A") for k in range(second)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("back", [3600, 600, 90])
@pytest.mark.parametrize("second", [1, 120])
def test_a_time_that_steps_back_is_named_and_counted(back, second, tmp_path, capsys):
    log = _log(tmp_path / "gps.log", 120, second, back)
    rc = main(["replay", "--no-zenoh", "--no-progress", str(log)])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert f"time stepped back: gps by {back - 1:.1f} s at its record 121" in out.out
    # every record after the step is behind (the second part is shorter than the step)
    behind = min(second, back - 1 - 60)
    assert f"{behind} of its records behind the replay's clock reached no estimator" in out.out
    assert "the time of gps stepped back" in out.err


def test_jitter_and_a_step_within_the_reorder_margin_are_not_a_step(tmp_path, capsys):
    log = _log(tmp_path / "gps.log", 120, 60, 30)  # 30 s back: late for the estimators, not two logs
    rc = main(["replay", "--no-zenoh", "--no-progress", str(log)])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "time stepped back" not in out.out
