"""`edged export FILE.mcap --topic T [--format csv|jsonl] [-o OUT]`: one topic as a table.

Rows are the messages' JSON payloads flattened with dots (`edged.flatten`), in file
order, plus the message's `log_time` (ns). CSV columns are the union over all rows
(first-seen order), found in a first pass so that memory does not grow with the file.

Only JSON messages can be exported (what edged records); a topic in another encoding
(a ROS 2 recording's `cdr`, protobuf ...) is refused by name, exit 2.
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

from edged.flatten import flatten
from edged.registry import Registry
from edged.subcommand import EXIT_OK, EXIT_USAGE, existing_file, fail, Subcommand

from ..reading import ReadReport, iter_messages
from edged.schemas import MESSAGE_ENCODING


class OutputError(OSError):
    """Writing the command's own output failed (not reading its input): the name is
    the output's (a file, or standard output)."""


class _NoTopic(LookupError):
    pass


class _Foreign(ValueError):
    """The topic's messages are in an encoding edged does not read (the description)."""


def _encoding(ch: Any, schema: Any) -> str:
    enc = repr(ch.message_encoding or "")
    if schema is not None and (schema.name or schema.encoding):
        enc += f" (schema {schema.name!r}" + (f", {schema.encoding}" if schema.encoding else "") + ")"
    return enc


def rows(path: Path, topic: str, report: ReadReport) -> Iterator[dict[str, Any]]:
    """Flat rows of `topic`; undecodable messages are counted in `report.orphans`;
    `_Foreign` for a topic that is not JSON."""
    with open(path, "rb") as f:
        for ch, schema, msg in iter_messages(f, report):
            if ch.topic != topic:
                continue
            if ch.message_encoding != MESSAGE_ENCODING:
                raise _Foreign(_encoding(ch, schema))
            try:
                payload = json.loads(msg.data)
            except ValueError:
                report.orphans += 1
                continue
            row = {"log_time": msg.log_time}
            row.update(flatten(payload) if isinstance(payload, dict) else {"value": payload})
            yield row


def cell(v: Any) -> Any:
    """A value as a CSV cell: empty for null, `repr` precision for floats."""
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return v


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


class _Sink:
    """The output stream, whose write errors say they are the output's: a failing
    write is an `OutputError` named after the output, a closed standard output the
    BrokenPipeError the command's wrapper answers."""

    def __init__(self, out: TextIO, name: str) -> None:
        self._out = out
        self._name = name

    def write(self, text: str) -> int:
        try:
            return self._out.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputError(exc.errno, exc.strerror or str(exc), self._name) from None

    def flush(self) -> None:
        try:
            self._out.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise OutputError(exc.errno, exc.strerror or str(exc), self._name) from None


def _discard(out_name: str) -> None:
    """Remove the output file a refused export created (never a device or a FIFO)."""
    p = Path(out_name)
    if p.is_file() and not p.is_symlink():
        p.unlink(missing_ok=True)


def main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    path = existing_file(args.file)
    if path is None:
        return EXIT_USAGE
    out_name = getattr(args, "output", None)
    if out_name and Path(out_name).exists() and Path(out_name).resolve() == path.resolve():
        return fail(f"{out_name}: is the recording being exported (-o would overwrite it)", EXIT_USAGE)
    try:
        target = open(out_name, "w", newline="", encoding="utf-8") if out_name else nullcontext(sys.stdout)
        with target as out:
            sink = _Sink(out, out_name or "standard output")
            n = _WRITERS[args.format](path, args.topic, sink)  # type: ignore[arg-type]
            sink.flush()
    except _Foreign as exc:
        if out_name:
            _discard(out_name)
        return fail(
            f"{path}: topic {args.topic!r} is encoded as {exc}: edged reads only "
            f"{MESSAGE_ENCODING!r} messages (recordings made by edged)",
            EXIT_USAGE,
        )
    except _NoTopic:
        if out_name:
            _discard(out_name)
        try:
            known = ", ".join(_topics(path)) or "none"
        except McapError:
            known = "none"
        return fail(f"{path}: no messages on topic {args.topic!r} (topics: {known})", EXIT_USAGE)
    except McapError as exc:
        return fail(f"{path}: {exc}")
    except BrokenPipeError:
        raise  # standard output closed by its reader: `command` says so
    except OSError as exc:
        return fail(f"{exc.filename or path}: {exc.strerror or exc}")
    if out_name:
        print(f"wrote {n} rows of {args.topic} to {out_name}", file=sys.stderr)
    return EXIT_OK


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.mcap")
    p.add_argument("--topic", required=True, metavar="T")
    p.add_argument("--format", choices=["csv", "jsonl"], default="csv")
    p.add_argument("-o", "--output", metavar="OUT", help="default: standard output")


#: `edged export` (entry point `edged.commands: export`).
COMMAND = Subcommand("one topic of a recording as CSV or JSON lines", arguments, main)
