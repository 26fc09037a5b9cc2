"""The files of a run: nmea.log, can.log, truth.csv, meta.json.

- `nmea.log`: one sentence a line, each behind an NMEA 4.10 TAG block carrying the
  receive time (`\\c:<unix s>.<ms>*hh\\$GPGGA,...*hh`), CR LF; injected garbage lines
  carry no TAG block, as noise on a serial line would not.
- `can.log`: candump -l (`(1732350000.123456) can0 09F11212#...`), 29-bit identifiers
  as 8 hex digits, 11-bit as 3.
- `truth.csv`: `truth.columns()` at the scenario's truth rate.
- `meta.json`: `Simulation.meta()` plus the files and their record counts.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import IO, Iterable

import numpy as np

from .emit import Batch
from .nmea0183 import tag_blocks
from .run import Chunk, Simulation
from .truth import columns

#: truth.csv formats: geodetic to ~0.1 mm, time to the millisecond, the rest to 9 digits.
_FORMATS = {"t": "%.3f", "t_rel": "%.3f", "lat": "%.10f", "lon": "%.10f"}


def nmea_lines(batch: Batch) -> list[str]:
    """TAG-blocked lines of a batch (garbage lines, key −1, go out bare)."""
    tags = tag_blocks(batch.t_us // 1000)
    return [s if k < 0 else t + s for t, s, k in zip(tags, batch.payload, batch.key.tolist())]


def candump_lines(batch: Batch, channel: str) -> list[str]:
    sec, us = (batch.t_us // 1_000_000).tolist(), (batch.t_us % 1_000_000).tolist()
    return [
        f"({s}.{u:06d}) {channel} {fid:08X}#{data.hex().upper()}" if ext else f"({s}.{u:06d}) {channel} {fid:03X}#{data.hex().upper()}"
        for s, u, (fid, ext, data) in zip(sec, us, batch.payload)
    ]


def write_truth(out: IO[str], truth: dict[str, np.ndarray]) -> None:
    cols = columns()
    table = np.column_stack([truth[c] for c in cols])
    np.savetxt(out, table, fmt=[_FORMATS.get(c, "%.9g") for c in cols], delimiter=",")


def write_run(sim: Simulation, out_dir: Path, chunk_s: float = 300.0) -> dict:
    """Simulate and write everything into out_dir; returns the meta data written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    channel = sim.scenario.can_channel
    counts = {"nmea.log": 0, "can.log": 0, "truth.csv": 0}
    with (
        open(out_dir / "nmea.log", "w", encoding="ascii", newline="\r\n") as nmea,
        open(out_dir / "can.log", "w", encoding="ascii", newline="\n") as can,
        open(out_dir / "truth.csv", "w", encoding="ascii", newline="\n") as truth,
    ):
        truth.write(",".join(columns()) + "\n")
        for chunk in sim.chunks(chunk_s):
            _write_lines(nmea, nmea_lines(chunk.nmea))
            _write_lines(can, candump_lines(chunk.can, channel))
            write_truth(truth, chunk.truth)
            counts["nmea.log"] += len(chunk.nmea.payload)
            counts["can.log"] += len(chunk.can.payload)
            counts["truth.csv"] += len(chunk.truth["t"])
    meta = sim.meta()
    meta["files"] = counts
    (out_dir / "meta.json").write_text(json.dumps(meta, indent=2, sort_keys=True, default=_json_default) + "\n")
    return meta


def _write_lines(out: IO[str], lines: Iterable[str]) -> None:
    text = "\n".join(lines)
    if text:
        out.write(text + "\n")


def _json_default(x: object) -> object:
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


__all__ = ["Chunk", "write_run", "nmea_lines", "candump_lines", "write_truth"]
