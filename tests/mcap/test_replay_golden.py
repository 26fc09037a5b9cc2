"""What a replay with the default configuration records stays the same, bit for bit,
while the code is made faster (issue 34).

The simulator's `demo` vessel (every sensor: NMEA 0183, NMEA 2000, the six draft marks,
the IMU) for 240 s, replayed with the built-in default configuration (the stw,
manoeuvre and draft estimators) and `--record`. Every channel's messages but the
health (wall-clock and machine figures) are hashed, in their order, with their log
times; `data/replay_golden.json` holds the hashes the code of 2026-12-05 gave
(commit 8d8bffe). Zenoh publishes the same JSON as the recording holds
(`tests/zenoh/test_same_json.py`), so a subscriber's samples are covered too.

A change that means to change an estimate (a better filter) writes the file again,
deliberately, in its own commit that says why:
    python tests/mcap/test_replay_golden.py --write
"""

from __future__ import annotations

import hashlib
import json
import platform
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from edged.cli import main as cli

GOLDEN = Path(__file__).parent / "data" / "replay_golden.json"
SCENARIO, SECONDS, SEED = "demo", "240", "7"


def digests(work: Path) -> dict[str, str]:
    """Simulate, replay with the default configuration and record; per channel, the
    SHA-256 of its messages (log time and payload) in order, and their count."""
    sim, rec = work / "sim", work / "replay.mcap"
    assert cli(["sim", SCENARIO, "--out", str(sim), "--duration", SECONDS, "--seed", SEED]) == 0
    logs = sorted(str(p) for p in sim.iterdir() if p.suffix in (".log", ".nmea"))
    assert logs, sorted(p.name for p in sim.iterdir())
    assert cli(["replay", *logs, "--record", str(rec), "--no-zenoh", "--no-progress"]) == 0
    hashes: dict[str, hashlib._Hash] = {}
    counts: dict[str, int] = {}
    with open(rec, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            if channel.topic == "/health":
                continue
            h = hashes.setdefault(channel.topic, hashlib.sha256())
            h.update(message.log_time.to_bytes(8, "little"))
            h.update(len(message.data).to_bytes(4, "little"))
            h.update(message.data)
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    return {t: f"{counts[t]} {hashes[t].hexdigest()}" for t in sorted(hashes)}


def machine() -> str:
    """What the estimates' last bits depend on: numpy (its OpenBLAS picks its kernels
    by CPU) and the CPU. The parsed measurements depend on neither."""
    model = "?"
    try:
        with open("/proc/cpuinfo") as f:
            model = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), "?")
    except OSError:
        pass
    return f"numpy {np.__version__}; {platform.machine()}; {model}"


def test_a_default_replay_records_what_it_recorded_before(tmp_path: Path) -> None:
    want = json.loads(GOLDEN.read_text())
    wrote_on = want.pop("_machine")
    got = digests(tmp_path)
    assert {"/est/stw", "/est/manoeuvre", "/est/draft"} <= set(got), sorted(got)
    changed = {t: (want.get(t), got.get(t)) for t in sorted(set(want) | set(got)) if want.get(t) != got.get(t)}
    measured = {t: d for t, d in changed.items() if not t.startswith("/est/")}
    assert not measured, measured  # parsing depends on no library's floating point
    if changed and machine() != wrote_on:
        pytest.skip(f"estimates differ on another machine class ({machine()}; written on {wrote_on}): "
                    f"their last bits follow numpy's BLAS kernels; {sorted(changed)}")
    assert not changed, changed


if __name__ == "__main__":  # pragma: no cover
    import tempfile

    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/mcap/test_replay_golden.py --write")
    with tempfile.TemporaryDirectory() as d:
        GOLDEN.write_text(json.dumps({"_machine": machine(), **digests(Path(d))}, indent=1) + "\n")
    print(f"wrote {GOLDEN}")
