"""Reading MCAP files record by record, finished or not.

A recording cut short by a power loss or `kill -9` has no summary and may end inside
a record; `mcap.reader.make_reader` refuses it. Here the file is read front to back
with the `mcap` package's stream reader: every complete chunk is used, a chunk that
fails its CRC or decompression is skipped and counted, and the first incomplete
record ends the file (counted as truncation) instead of raising.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import IO, Iterator

from mcap.exceptions import EndOfFile, McapError
from mcap.records import Channel, Chunk, Footer, McapRecord, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

__all__ = ["ReadReport", "iter_records", "iter_messages", "MAGIC"]

MAGIC = b"\x89MCAP0\r\n"

#: What an incomplete record at the end of a file raises while being parsed.
_TRUNCATION = (EndOfFile, struct.error, UnicodeDecodeError)


@dataclass
class ReadReport:
    """How a file read: complete or not, and what had to be skipped."""

    chunks: int = 0
    messages: int = 0
    bad_chunks: int = 0
    #: Messages whose channel record was lost (in a skipped chunk): not readable.
    orphans: int = 0
    #: The footer was reached: the writer finished the file.
    finished: bool = False
    #: The footer points at a summary section (indexes, statistics).
    summary: bool = False
    #: The file ends inside a record (unfinished write).
    truncated: bool = False
    #: A record that is neither complete nor at the end: reading stopped there.
    error: str | None = None
    bad_chunk_errors: list[str] = field(default_factory=list)

    @property
    def healthy(self) -> bool:
        return self.finished and self.bad_chunks == 0 and self.error is None


def _chunk_records(chunk: Chunk, report: ReadReport) -> list[McapRecord]:
    try:
        recs = breakup_chunk(chunk, validate_crc=True)
    except Exception as exc:  # CRC, decompression, a broken record inside: skip the chunk
        report.bad_chunks += 1
        if len(report.bad_chunk_errors) < 10:
            report.bad_chunk_errors.append(f"{type(exc).__name__}: {exc}")
        return []
    report.chunks += 1
    return recs


def iter_records(stream: IO[bytes], report: ReadReport) -> Iterator[McapRecord]:
    """Every record of the file in file order, chunks opened; never raises on content.

    `report` is filled in as the file is read and is complete once the iterator is
    exhausted. Raises `McapError` only when the file is not MCAP at all (bad magic).
    """
    reader = StreamReader(stream, emit_chunks=True, record_size_limit=1 << 30)
    records = reader.records
    first = True
    while True:
        try:
            rec = next(records)
        except StopIteration:
            return
        except _TRUNCATION:
            if first:
                raise McapError("not an MCAP file (too short)") from None
            report.truncated = True
            return
        except McapError as exc:
            if first:
                raise
            report.error = f"{type(exc).__name__}: {exc}"
            return
        first = False
        if isinstance(rec, Chunk):
            for r in _chunk_records(rec, report):
                if isinstance(r, Message):
                    report.messages += 1
                yield r
            continue
        if isinstance(rec, Message):
            report.messages += 1
        elif isinstance(rec, Footer):
            report.finished = True
            report.summary = rec.summary_start != 0
        yield rec


def iter_messages(
    stream: IO[bytes], report: ReadReport
) -> Iterator[tuple[Channel, Schema | None, Message]]:
    """Messages with their channel and schema, in file order (publish order)."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    for rec in iter_records(stream, report):
        if isinstance(rec, Message):
            ch = channels.get(rec.channel_id)
            if ch is None:
                report.orphans += 1
                continue
            yield ch, schemas.get(ch.schema_id), rec
        elif isinstance(rec, Channel):
            channels[rec.id] = rec
        elif isinstance(rec, Schema):
            schemas[rec.id] = rec
