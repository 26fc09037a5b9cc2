"""kill -9 while recording, then `edged recover`: everything up to the last complete chunk is back."""

from __future__ import annotations

import hashlib
import json
import os
import selectors
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from mcap.reader import make_reader

from edged.cli import main as cli

_CHILD = textwrap.dedent(
    """
    import asyncio, sys
    from edged.clock import ManualClock
    from edged.health import ComponentHealth
    from edged.plugin import PluginContext
    from edged.records import RawRecord
    from edged_mcap.recorder import McapRecorder

    clock = ManualClock(1_732_350_000.0)
    health = ComponentHealth("rec", "output", "mcap", clock)
    ctx = PluginContext("rec", clock, health, lambda r: None)
    cfg = McapRecorder.Config.model_validate(
        {"type": "mcap", "path": sys.argv[1], "chunk_kib": 2, "fsync": False}
    )
    rec = McapRecorder(cfg, ctx)
    asyncio.run(rec.open())
    i = 0
    while True:
        batch = []
        for _ in range(50):
            batch.append(RawRecord("nmea0183", "g", 1_732_350_000.0 + i * 0.001, b"$N,%d*00" % i, {"i": i}))
            i += 1
        rec.write(batch)
        clock.step(0.05)
        if i % 200 == 0:
            rec.flush()
            print(i, flush=True)  # everything up to i is in complete chunks now
        if i > 200_000:
            break
    """
)


def _run_until(path: Path, flushed_at_least: int) -> int:
    """Start the recording child, kill -9 it once it reported enough; return its last report."""
    proc = subprocess.Popen([sys.executable, "-c", _CHILD, str(path)], stdout=subprocess.PIPE, text=True)
    last = 0
    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ)
    try:
        while last < flushed_at_least:
            if not sel.select(timeout=30):  # safety net only: the child reports every few ms
                pytest.fail("recording child went silent")
            line = proc.stdout.readline()
            if not line:
                pytest.fail(f"recording child ended early (exit {proc.wait()})")
            last = int(line)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        sel.close()
        proc.stdout.close()
    assert proc.returncode == -signal.SIGKILL
    return last


def test_kill_9_then_recover_brings_back_everything_flushed(tmp_path, capsys):
    path = tmp_path / "crash.mcap"
    reported = _run_until(path, 3000)
    with open(path, "rb") as f:
        with pytest.raises(Exception):  # the official reader refuses an unfinished file
            list(make_reader(f).iter_messages())
    before = hashlib.sha256(path.read_bytes()).hexdigest()

    assert cli(["recover", str(path)]) == 0
    out = capsys.readouterr().out
    assert "unfinished" in out

    assert hashlib.sha256(path.read_bytes()).hexdigest() == before  # original untouched
    recovered = tmp_path / "crash.recovered.mcap"
    with open(recovered, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes  # indexed
        ids = [json.loads(m.data)["meta"]["i"] for _, _, m in reader.iter_messages()]
    assert len(ids) >= reported  # nothing flushed before the kill is lost
    assert ids == list(range(len(ids)))  # and nothing out of order or invented
    with open(recovered, "rb") as f:
        (meta,) = list(make_reader(f).iter_metadata())
    assert meta.name == "edged"


def test_recover_a_complete_file_copies_it_and_replay_reads_the_unfinished_one(tmp_path, capsys):
    path = tmp_path / "c.mcap"
    _run_until(path, 400)
    # Replay reads the unfinished file directly, without recovery.
    from edged.clock import ManualClock
    from edged.health import ComponentHealth
    from edged.plugin import ReplayOptions
    from edged_mcap.logs import MCAP

    health = ComponentHealth("c", "input", "mcap", ManualClock(0))
    with open(path, "rb") as f:
        raws = list(MCAP.open(f, "c", health, ReplayOptions()))
    assert len(raws) >= 400 and health.counters["truncated"] == 1

    assert cli(["recover", str(path)]) == 0
    first = tmp_path / "c.recovered.mcap"
    assert cli(["recover", str(first)]) == 0  # a finished file: copied as it is
    assert "was complete" in capsys.readouterr().out
    second = tmp_path / "c.recovered.recovered.mcap"
    with open(first, "rb") as a, open(second, "rb") as b:
        assert [m.data for _, _, m in make_reader(a).iter_messages()] == [
            m.data for _, _, m in make_reader(b).iter_messages()
        ]


def test_recover_rejects_what_it_cannot_use(tmp_path, capsys):
    assert cli(["recover", str(tmp_path / "missing.mcap")]) == 2
    not_mcap = tmp_path / "x.mcap"
    not_mcap.write_bytes(b"$GPGGA,hello\r\n")
    assert cli(["recover", str(not_mcap)]) == 1
    assert "not a valid MCAP" in capsys.readouterr().err
    assert not (tmp_path / "x.recovered.mcap").exists()
    assert sorted(os.listdir(tmp_path)) == ["x.mcap"]  # no partial output left behind
