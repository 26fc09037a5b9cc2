"""Logs (simulated or real) as the measurements an estimator core sees, in time order.

`measurements(paths)` reads each file with its log reader and decodes every raw record
with the decoder of its input, as `edged replay` does, then merges them by time.
`select(ms, kinds)` keeps one source per kind (the first seen, as the worker host's
source priority does by default) or those named.
"""

from __future__ import annotations

import heapq
import io
from pathlib import Path
from typing import Iterable

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import Measurement
from edged.registry import Registry
from edged.logformats import detect


def measurements(paths: Iterable[Path], date: str | None = None) -> list[Measurement]:
    registry = Registry()
    streams = []
    decoders: dict[tuple[str, str], object] = {}
    for path in paths:
        _, reader = detect(Path(path), registry)
        health = ComponentHealth(Path(path).stem, "input", reader.input or reader.name, ManualClock(0.0))
        f = io.BufferedReader(open(path, "rb"), 1 << 16)
        out: list[Measurement] = []
        for raw in reader.open(f, Path(path).stem, health, ReplayOptions(date=date)):
            key = (raw.protocol, raw.source)
            dec = decoders.get(key)
            if dec is None:
                cls = registry.get("inputs", reader.input or raw.protocol)
                dec = decoders[key] = cls.make_decoder(raw.source, None, health)
            out.extend(dec.decode(raw))
        f.close()
        out.sort(key=lambda m: m.t)
        streams.append(out)
    return list(heapq.merge(*streams, key=lambda m: m.t))


def select(ms: list[Measurement], kinds: Iterable[str], sources: dict[str, str] | None = None) -> list[Measurement]:
    """One source per kind: `sources[kind]` when given, else the first seen."""
    want = set(kinds)
    chosen = dict(sources or {})
    out = []
    for m in ms:
        if m.kind not in want:
            continue
        src = chosen.setdefault(m.kind, m.source)
        if m.source == src:
            out.append(m)
    return out
