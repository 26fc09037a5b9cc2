"""`edged replay <nmea log> --no-zenoh` end to end (installed entry points, real CLI)."""

from __future__ import annotations

import subprocess
import sys
from functools import reduce
from operator import xor
from pathlib import Path


def _nmea(body: str) -> str:
    return "$%s*%02X" % (body, reduce(xor, body.encode(), 0))


def _tag(t: str) -> str:
    text = f"c:{t}"
    return "\\%s*%02X\\" % (text, reduce(xor, text.encode(), 0))


def edged(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "edged.cli", *args], capture_output=True, text=True, timeout=120, cwd=cwd
    )


def test_replay_prints_the_summary_from_our_counters(tmp_path):
    log = tmp_path / "bridge.nmea"
    log.write_text(
        "# a comment header\r\n"
        + "\r\n".join(
            [
                _nmea("HEHDT,10.0,T"),  # before any time: rejected.no_time
                _tag("1717200000") + _nmea("GPGGA,000000,5230.0,N,00430.0,E,1,08,0.9,1.0,M,46.0,M,,"),
                _tag("1717200001") + _nmea("HEHDT,12.5,T"),
                _tag("1717200001") + "$HEHDT,13.0,T*00",  # bad checksum
                _tag("1717200002") + _nmea("GPHDT,,T"),  # empty: invalid
            ]
        )
        + "\r\n"
    )
    r = edged("replay", str(log), "--no-zenoh", "--no-progress", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    for counter, n in [
        ("lines", 5),
        ("accepted", 3),
        ("rejected.no_time", 1),
        ("rejected.checksum", 1),
        ("comments", 1),
        ("sentences.HDT", 2),
        ("invalid.HDT", 1),
        ("measurements.heading", 1),
        ("measurements.position", 1),
    ]:
        assert any(line.split()[-2:] == [counter, str(n)] for line in out.splitlines()), (counter, out)


def test_check_config_names_the_key(tmp_path):
    cfg = tmp_path / "edged.toml"
    cfg.write_text('[inputs.gnss1]\ntype = "nmea0183"\ntransport = "tcp"\nport = 10110\n')
    r = edged("check-config", str(cfg), cwd=tmp_path)
    assert r.returncode == 2
    assert "inputs.gnss1.host" in r.stdout + r.stderr
