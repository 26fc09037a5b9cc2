"""What the generalisation harnesses share: running `edged` as a user does, reading a
recording's estimates and health, and printing markdown tables.

The harnesses judge the default configuration through the command line (`edged sim`,
`edged replay --no-zenoh --record`, `edged score --json`), never through the cores'
Python objects, so that what they measure is what a user gets. `edged` runs as
`python -m edged.cli` under the same interpreter and environment: with
`PYTHONPATH=<a checkout>:<a checkout>/plugins` the harness judges that checkout's code.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

from edged_mcap.reading import ReadReport, iter_messages

EDGED = [sys.executable, "-m", "edged.cli"]
DEG = 180.0 / math.pi


@dataclass
class Done:
    """One command's exit code and the tail of what it said."""

    rc: int
    stdout: str
    stderr_tail: str


def edged(*args: str, timeout: float | None = None) -> Done:
    """`edged ARGS...`; never raises for a non-zero exit (the harness reports it)."""
    env = dict(os.environ)
    for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env.setdefault(v, "1")  # one core per job: the machine is shared
    try:
        p = subprocess.run(EDGED + list(args), capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired as exc:
        return Done(-9, "", f"timed out after {exc.timeout:.0f} s")
    return Done(p.returncode, p.stdout, "\n".join(p.stderr.strip().splitlines()[-5:]))


def replay(inputs: Sequence[Path], record: Path, timeout: float | None = None) -> Done:
    """`edged replay INPUT... --no-zenoh --no-progress --record OUT` with the built-in
    default configuration."""
    return edged("replay", *map(str, inputs), "--no-zenoh", "--no-progress", "--record", str(record), timeout=timeout)


def recordings(record: Path) -> list[Path]:
    """The file and its rotated continuations (`OUT.001.mcap`, ...), in order."""
    more = sorted(record.parent.glob(f"{record.stem}.[0-9][0-9][0-9].mcap"))
    return ([record] if record.exists() else []) + more


@dataclass
class Recorded:
    """Decoded payloads of the wanted topics, in file order, and how the file read."""

    topics: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    truncated: bool = False

    def get(self, topic: str) -> list[dict[str, Any]]:
        return self.topics.get(topic, [])


def read(record: Path, wanted: Iterable[str] = (), prefixes: Iterable[str] = ()) -> Recorded:
    """The payloads of topics named in `wanted` or starting with one of `prefixes`
    (read front to back by edged_mcap's reader: an unfinished file reads too)."""
    want, pre = set(wanted), tuple(prefixes)
    out = Recorded()
    for path in recordings(record):
        report = ReadReport()
        with path.open("rb") as f:
            for ch, _, msg in iter_messages(f, report):
                if ch.topic in want or (pre and ch.topic.startswith(pre)):
                    out.topics.setdefault(ch.topic, []).append(json.loads(msg.data))
        out.truncated |= bool(getattr(report, "truncated", False))
    return out


def health_of(snapshots: list[dict[str, Any]], estimator: str) -> list[tuple[float, bool, list[str]]]:
    """(t, ok, problems) of one estimator's health component over time."""
    rows = []
    for h in snapshots:
        c = (h.get("estimators") or {}).get(estimator)
        if isinstance(c, dict):
            rows.append((float(h["t"]), c.get("ok") is not False, list(c.get("problems") or [])))
    return rows


def problems_seen(rows: list[tuple[float, bool, list[str]]], limit: int = 3, width: int = 110) -> str:
    """The distinct problems named, most frequent first, shortened for a table. Texts
    that differ only in their numbers (a NIS that moves, a time) count as one, shown
    by their latest wording."""
    counts: dict[str, int] = {}
    latest: dict[str, str] = {}
    for _, _, ps in rows:
        for p in ps:
            key = _NUMBER.sub("#", p)
            counts[key] = counts.get(key, 0) + 1
            latest[key] = p
    texts = [latest[k] for k, _ in sorted(counts.items(), key=lambda kv: -kv[1])]
    texts = [p if len(p) <= width else p[:width - 1] + "…" for p in texts]
    more = f" (+{len(texts) - limit})" if len(texts) > limit else ""
    return "; ".join(texts[:limit]) + more if texts else "-"


_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join("" if c is None else str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def num(x: float | None, digits: int = 3) -> str:
    """A figure for a table: `-` for none, else `digits` significant digits."""
    if x is None or not math.isfinite(x):
        return "-"
    if x == 0:
        return "0"
    return f"{x:.{digits}g}" if abs(x) < 10 ** digits else f"{x:.0f}"


def display(value: float | None, unit: str) -> tuple[float | None, str]:
    """An error in the unit a mariner reads: degrees and °/s for radians, else as is."""
    if value is None:
        return None, unit
    if unit == "rad":
        return value * DEG, "°"
    if unit == "rad/s":
        return value * DEG, "°/s"
    return value, unit
