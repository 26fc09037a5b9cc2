"""`edged inspect FILE.mcap`: channels, counts, rates, time span, gaps, file health."""

from __future__ import annotations

import argparse
from datetime import datetime, timezone
import sys
from typing import TextIO

from mcap.exceptions import McapError

from edged.registry import Registry
from edged.subcommand import EXIT_OK, EXIT_USAGE, existing_file, fail, Subcommand

from ..stats import FileStats, file_stats

def _utc(ns: int | None) -> str:
    if ns is None:
        return "-"
    d = datetime.fromtimestamp(ns // 1_000_000_000, tz=timezone.utc)
    return d.strftime("%Y-%m-%dT%H:%M:%S") + f".{ns % 1_000_000_000 // 1_000_000:03d}Z"


def _health(s: FileStats) -> str:
    r = s.report
    parts = []
    if r.finished:
        parts.append("finished" + (", summary present" if r.summary else ", no summary"))
    else:
        why = r.unfinished_why
        parts.append(f"UNFINISHED ({why}): run `edged recover {s.path}`")
    if r.bad_chunks:
        parts.append(f"{r.bad_chunks} damaged chunk(s) skipped")
    if r.orphans:
        parts.append(f"{r.orphans} message(s) without a channel")
    return "; ".join(parts)


def render(s: FileStats, out: TextIO) -> None:
    meta = s.metadata.get("edged", {})
    first, last = s.first_ns, s.last_ns
    span = (last - first) / 1e9 if first is not None and last is not None else 0.0
    print(f"file      {s.path} ({s.size / 1048576:.2f} MiB, {s.report.chunks} chunks)", file=out)
    print(f"health    {_health(s)}", file=out)
    if meta:
        print(f"vessel    {meta.get('vessel_id', '?')}  (edged {meta.get('edged_version', '?')})", file=out)
    print(f"span      {_utc(first)} .. {_utc(last)}  ({span:.3f} s)", file=out)
    print(f"messages  {s.messages} on {len(s.channels)} channels", file=out)
    print(file=out)
    rows = sorted(s.channels.values(), key=lambda c: c.topic)
    w = max([len("topic"), *(len(c.topic) for c in rows)])
    ws = max([len("schema"), *(len(c.schema) for c in rows)])
    print(f"{'topic':<{w}}  {'schema':<{ws}}  {'count':>9}  {'rate Hz':>9}  {'span s':>10}  {'max gap s':>10}  gap at", file=out)
    for c in rows:
        rate = f"{c.rate_hz:9.3f}" if c.rate_hz is not None else f"{'-':>9}"
        gap = f"{c.max_gap_ns / 1e9:10.3f}" if c.count > 1 else f"{'-':>10}"
        at = _utc(c.max_gap_at_ns) if c.max_gap_at_ns is not None else "-"
        back = f"  ({c.backwards} out of order)" if c.backwards else ""
        print(f"{c.topic:<{w}}  {c.schema:<{ws}}  {c.count:>9}  {rate}  {c.span_s:10.3f}  {gap}  {at}{back}", file=out)


def main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    path = existing_file(args.file)
    if path is None:
        return EXIT_USAGE
    try:
        s = file_stats(path)
    except McapError as exc:
        return fail(f"{path}: {exc}")
    except OSError as exc:
        return fail(f"{path}: {exc.strerror or exc}")
    render(s, sys.stdout)
    return EXIT_OK


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.mcap")


#: `edged inspect` (entry point `edged.commands: inspect`).
COMMAND = Subcommand("channels, counts, rates, time span, gaps of a recording", arguments, main)
