"""MCAP recordings for `edged score` and `edged plot` (entry point `mcap`, group
`edged.recordings`; the contract is `edged.recordings.RecordingReader`).

Read with `reading.iter_messages`, so that an unfinished or damaged file gives what
it holds. Light on purpose, as the log reader: finding the reader of a file loads
every installed one, and the mcap library is imported only to read a recording.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator

import orjson

from edged.recordings import RecordedMessage, RecordingError, RecordingReport, every_topic

from .logs import MAGIC

__all__ = ["McapRecordings", "RECORDINGS", "decode"]

#: `decode`'s answer for a payload that is not JSON.
UNDECODABLE: Any = object()


def decode(data: bytes) -> Any:
    """A payload as the standard library decodes it, at orjson's speed where orjson
    agrees (every payload edged writes); `UNDECODABLE` when it is not JSON. orjson
    refuses some JSON the standard library takes (NaN, integers beyond any float, a
    byte-order mark): those are decoded by the standard library."""
    try:
        return orjson.loads(data)
    except orjson.JSONDecodeError:
        pass
    try:
        return json.loads(data)
    except (ValueError, RecursionError):  # not JSON, or nested beyond any payload's depth
        return UNDECODABLE


@dataclass(frozen=True)
class McapRecordings:
    """MCAP files, edged's recordings or any with JSON messages."""

    name: str = "mcap"

    def sniff(self, head: bytes) -> bool:
        return head.startswith(MAGIC)

    def messages(
        self, path: Path, report: RecordingReport, wanted: Callable[[str], bool] = every_topic
    ) -> Iterator[RecordedMessage]:
        """The messages of the `wanted` topics (`edged.recordings.RecordingReader`)."""
        from mcap.exceptions import McapError

        from .reading import ReadReport, iter_messages

        read = ReadReport()
        try:
            with open(path, "rb") as f:
                for ch, schema, msg in iter_messages(f, read):
                    if not wanted(ch.topic):
                        continue
                    payload = decode(msg.data)
                    if payload is UNDECODABLE:
                        report.undecodable += 1
                        continue
                    yield RecordedMessage(ch.topic, None if schema is None else schema.name, msg.log_time, payload)
        except McapError as exc:
            raise RecordingError(str(exc)) from exc
        finally:
            report.finished = read.finished
            report.unfinished_why = "" if read.finished else read.unfinished_why
            report.bad_chunks = read.bad_chunks
            report.orphans = read.orphans


#: The reader (entry point `edged.recordings: mcap`).
RECORDINGS = McapRecordings()
