"""Real logs: replaying the recording of a replay gives the very same raw data and measurements.

This is the promise of DESIGN §4 (MCAP inputs are decoded again): what `edged replay
LOG --record A.mcap` recorded, `edged replay A.mcap --record B.mcap` reproduces exactly.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from pathlib import Path

import pytest
from mcap.reader import make_reader

from edged.cli import main as cli

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
LOGS = [
    ("nmea0183", "nmea0183/signalk-server__samples__gofree-merrimac.log"),
    ("can", "n2k/canboat__samples__candumpSample2.txt"),
]


def _content(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    with open(path, "rb") as f:
        for _, ch, m in make_reader(f).iter_messages(log_time_order=False):
            if ch.topic != "/health":  # health counts differ by design (other inputs)
                out.setdefault(ch.topic, []).append((m.log_time, m.data))
    return out


@pytest.mark.parametrize(("plugin", "log"), LOGS)
def test_replaying_a_recording_reproduces_it(tmp_path, plugin, log):
    src = DATA / log
    if not src.is_file():
        pytest.skip(f"../shared data not here: {src} not found")
    assert entry_points(group="edged.inputs", name=plugin), f"first-party input plugin {plugin} not installed"
    first, second = tmp_path / "a.mcap", tmp_path / "b.mcap"
    assert cli(["replay", str(src), "--record", str(first), "--no-zenoh", "--no-progress"]) == 0
    assert cli(["replay", str(first), "--record", str(second), "--no-zenoh", "--no-progress"]) == 0
    a, b = _content(first), _content(second)
    assert any(t.startswith("/raw/") for t in a) and any(t.startswith("/meas/") for t in a)
    assert a == b
