"""`edged export FILE.mcap --topic T [--format csv|jsonl] [-o OUT]`: one topic as a table.

Rows are the messages' JSON payloads flattened with dots, in file order, plus the
message's `log_time` (ns). CSV columns are the union over all rows (first-seen order),
found in a first pass so that memory does not grow with the file.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from contextlib import nullcontext
from pathlib import Path
from typing import Any, Iterator, TextIO

from mcap.exceptions import McapError

from ..flatten import cell, flatten
from ..reading import ReadReport, iter_messages
from ._common import EXIT_OK, EXIT_USAGE, existing_file, fail


class _NoTopic(LookupError):
    pass


def rows(path: Path, topic: str, report: ReadReport) -> Iterator[dict[str, Any]]:
    """Flat rows of `topic`; undecodable messages are counted in `report.orphans`."""
    with open(path, "rb") as f:
        for ch, _schema, msg in iter_messages(f, report):
            if ch.topic != topic:
                continue
            try:
                payload = json.loads(msg.data)
            except ValueError:
                report.orphans += 1
                continue
            row = {"log_time": msg.log_time}
            row.update(flatten(payload) if isinstance(payload, dict) else {"value": payload})
            yield row


def _topics(path: Path) -> list[str]:
    seen: set[str] = set()
    with open(path, "rb") as f:
        for ch, _s, _m in iter_messages(f, ReadReport()):
            seen.add(ch.topic)
    return sorted(seen)


def write_csv(path: Path, topic: str, out: TextIO) -> int:
    columns: dict[str, None] = {}
    n = 0
    for r in rows(path, topic, ReadReport()):
        columns.update(dict.fromkeys(r))
        n += 1
    if n == 0:
        raise _NoTopic(topic)
    w = csv.DictWriter(out, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    for r in rows(path, topic, ReadReport()):
        w.writerow({k: cell(v) for k, v in r.items()})
    return n


def write_jsonl(path: Path, topic: str, out: TextIO) -> int:
    n = 0
    for r in rows(path, topic, ReadReport()):
        out.write(json.dumps(r, separators=(",", ":")) + "\n")
        n += 1
    if n == 0:
        raise _NoTopic(topic)
    return n


_WRITERS = {"csv": write_csv, "jsonl": write_jsonl}


def main(args: argparse.Namespace) -> int:
    path = existing_file(args.file)
    if path is None:
        return EXIT_USAGE
    out_name = getattr(args, "output", None)
    try:
        target = open(out_name, "w", newline="", encoding="utf-8") if out_name else nullcontext(sys.stdout)
        with target as out:
            n = _WRITERS[args.format](path, args.topic, out)
    except _NoTopic:
        if out_name:
            Path(out_name).unlink(missing_ok=True)
        try:
            known = ", ".join(_topics(path)) or "none"
        except McapError:
            known = "none"
        return fail(f"{path}: no messages on topic {args.topic!r} (topics: {known})", EXIT_USAGE)
    except McapError as exc:
        return fail(f"{path}: {exc}")
    except OSError as exc:
        return fail(f"{exc.filename or path}: {exc.strerror or exc}")
    if out_name:
        print(f"wrote {n} rows of {args.topic} to {out_name}", file=sys.stderr)
    return EXIT_OK
