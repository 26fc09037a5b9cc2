"""Reading MCAP files record by record, finished, unfinished or damaged.

A recording cut short by a power loss or `kill -9` has no summary and may end inside
a record; `mcap.reader.make_reader` refuses it. Here the file is read front to back:
every complete chunk is used, a chunk that fails its CRC or decompression is skipped
and counted, and the first incomplete record ends the file (counted as truncation)
instead of raising.

Damaged or foreign files must not cost more memory than they hold: every length field
is checked before anything is allocated for it. A record is read into memory only
when its declared length is within `max_record` (1 GiB) and it is then read in pieces,
so that a length beyond the end of the file costs what the file holds, not what the
field claims; the record's own fields are parsed from those bytes only, never from
the file; a chunk is decompressed only when its declared uncompressed size is within
`max_record`, and never into more than it declared; one that inflates to more than
`INFLATE_WHOLE` (16 MiB) is read in pieces, so that a few KB on disk that inflate to a
GiB cost a piece and a record, not the GiB. A length that cannot be true
stops the reading there (`ReadReport.error`, "damaged: ..."): what came before it
has been read. A length beyond the end of the file cannot be told from a write cut
short: it ends the file as truncation.

A file that has the MCAP magic but no header after it (only the magic, a header cut
short, another record first) raises `NoRecords`: it is refused as an empty file is.
Index and statistics records are skipped unparsed: reading front to back does not
need them, and `edged recover` writes new ones. The chunks are `chunks`'s, the shared
parts (the report, the damage, reading a length) `readbase`'s.
"""

from __future__ import annotations

import os
from typing import IO, Callable, Iterator

from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    Channel,
    Chunk,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Message,
    Metadata,
    Schema,
)

from .chunks import chunk_records
from .readbase import (
    KEEP_ERRORS,
    RECORD_HEAD,
    Body,
    Damage,
    NoRecords,
    ReadReport,
    bad_chunk,
    opcode_name,
    read_up_to,
    why,
)

__all__ = ["ReadReport", "NoRecords", "iter_records", "iter_messages", "messages_after", "MAGIC", "MAX_RECORD"]

MAGIC = b"\x89MCAP0\r\n"

#: The largest record, and the largest uncompressed chunk, that is read (bytes). The
#: recorder writes chunks of at most 1 MiB; other writers' chunks are a few MiB.
MAX_RECORD = 1 << 30

#: opcode -> parser of the record's bytes. The records read front to back need: the
#: indexes and statistics of the summary are skipped unparsed (`recover` rebuilds them).
_PARSE: dict[int, Callable[[bytes], McapRecord]] = {
    Opcode.HEADER: lambda b: Header.read(Body(b)),
    Opcode.FOOTER: lambda b: Footer.read(Body(b)),
    Opcode.SCHEMA: lambda b: Schema.read(Body(b)),
    Opcode.CHANNEL: lambda b: Channel.read(Body(b)),
    Opcode.MESSAGE: lambda b: Message.read(Body(b), len(b)),
    Opcode.CHUNK: lambda b: Chunk.read(Body(b)),
    Opcode.ATTACHMENT: lambda b: Attachment.read(Body(b)),
    Opcode.METADATA: lambda b: Metadata.read(Body(b)),
    Opcode.DATA_END: lambda b: DataEnd.read(Body(b)),
}


def _check_magic(stream: IO[bytes]) -> None:
    """McapError unless the file begins with the MCAP magic."""
    magic = read_up_to(stream, len(MAGIC))
    if magic != MAGIC:
        if magic and MAGIC.startswith(magic):
            raise McapError("not an MCAP file (too short)")
        raise McapError("not a valid MCAP file (it does not begin with the MCAP magic)")


def _parse(opcode: int, body: bytes, at: int, report: ReadReport) -> McapRecord | None:
    """The record of `body`; None for one that is not read front to back (indexes,
    statistics, records of a later MCAP version) or whose fields do not fit its bytes
    (counted in `report`: a bad chunk, or a bad record)."""
    parse = _PARSE.get(opcode)
    if parse is None:
        return None
    try:
        return parse(body)
    except Exception as exc:  # its fields do not fit its bytes
        if opcode == Opcode.CHUNK:
            bad_chunk(report, Damage(f"CHUNK record at byte {at}: {why(exc)}"))
        else:
            report.bad_records += 1
            if len(report.bad_record_errors) < KEEP_ERRORS:
                report.bad_record_errors.append(f"{opcode_name(opcode)} record at byte {at}: {why(exc)}")
        return None


def _after_footer(stream: IO[bytes], report: ReadReport, at: int) -> None:
    """The footer (at byte `at`) must be followed by the magic, the file's last bytes."""
    tail = read_up_to(stream, len(MAGIC))
    if len(tail) < len(MAGIC):
        report.truncated = True
    elif tail != MAGIC:
        report.error = f"damaged: the footer at byte {at} is not followed by the MCAP magic"


def iter_records(stream: IO[bytes], report: ReadReport, *, max_record: int | None = None) -> Iterator[McapRecord]:
    """Every content record of the file in file order, chunks opened; never raises on content.

    `report` is filled in as the file is read and is complete once the iterator is
    exhausted. Raises `McapError` only when the file is not MCAP at all (bad magic), and
    its subclass `NoRecords` when it holds the magic but not one complete record.
    OSError from the stream is passed on. No record longer than `max_record` (default
    `MAX_RECORD`) is read, and no chunk decompressed to more.
    """
    if max_record is None:
        max_record = MAX_RECORD
    _check_magic(stream)
    header, pos = _first_record(stream, max_record)
    yield header
    head_size = RECORD_HEAD.size
    while True:
        head = read_up_to(stream, head_size)
        if len(head) < head_size:
            report.truncated = True
            return
        opcode, length = RECORD_HEAD.unpack(head)
        if length > max_record:
            what = opcode_name(opcode)
            report.error = f"damaged: {what} record at byte {pos} claims {length} bytes (limit {max_record})"
            return
        body = read_up_to(stream, length)
        if len(body) < length:
            report.truncated = True
            return
        at = pos
        pos += head_size + length
        rec = _parse(opcode, body, at, report)
        if rec is None:
            continue
        if isinstance(rec, Chunk):
            for r in chunk_records(rec, report, max_record):
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
        if isinstance(rec, Footer):
            _after_footer(stream, report, at)
            return


def _first_record(stream: IO[bytes], max_record: int) -> tuple[Header, int]:
    """The header every MCAP file begins with, and the offset after it; `NoRecords`
    when the file holds only the magic, ends inside its first record, or does not begin
    with a header at all (so that it is refused as an empty file is)."""
    at = len(MAGIC)
    head = read_up_to(stream, RECORD_HEAD.size)
    if not head:
        raise NoRecords("holds only the MCAP magic")
    if len(head) < RECORD_HEAD.size:
        raise NoRecords("ends inside its first record")
    opcode, length = RECORD_HEAD.unpack(head)
    if opcode != Opcode.HEADER:
        raise NoRecords(f"begins with a {opcode_name(opcode)} record, not the MCAP header")
    if length > max_record:
        raise NoRecords(f"is damaged: its header claims {length} bytes (limit {max_record})")
    body = read_up_to(stream, length)
    if len(body) < length:
        raise NoRecords("ends inside its first record")
    try:
        header = Header.read(Body(body))
    except Exception as exc:  # its fields do not fit its bytes
        raise NoRecords(f"is damaged: its header at byte {at}: {why(exc)}") from None
    return header, at + RECORD_HEAD.size + length


def iter_messages(
    stream: IO[bytes], report: ReadReport, *, max_record: int | None = None
) -> Iterator[tuple[Channel, Schema | None, Message]]:
    """Messages with their channel and schema, in file order (publish order)."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    for rec in iter_records(stream, report, max_record=max_record):
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


def messages_after(path: str | os.PathLike[str], offset: int, skip: set[int], skip_prefix: str) -> int:
    """Messages in the complete chunks of the file from byte `offset` (where a record
    begins) to where it ends or is cut, leaving out those of the channels in `skip` and
    of channels read there whose topic begins with `skip_prefix`. What a recorder
    killed between two flushes had written past its last one (a short read: a second
    of data)."""
    report = ReadReport()
    skip = set(skip)
    n = 0
    head_size = RECORD_HEAD.size
    with open(path, "rb") as stream:
        stream.seek(offset)
        while True:
            head = read_up_to(stream, head_size)
            if len(head) < head_size:
                return n
            opcode, length = RECORD_HEAD.unpack(head)
            if length > MAX_RECORD:
                return n
            body = read_up_to(stream, length)
            if len(body) < length:
                return n  # the record the kill cut short
            if opcode == Opcode.CHANNEL:
                try:
                    records: Iterator[McapRecord] = iter([_PARSE[opcode](body)])
                except Exception:  # its fields do not fit its bytes
                    continue
            elif opcode == Opcode.CHUNK:
                try:
                    chunk = _PARSE[opcode](body)
                except Exception:  # a chunk that does not parse holds nothing readable
                    continue
                records = chunk_records(chunk, report, MAX_RECORD)  # type: ignore[arg-type]
            else:
                continue
            for rec in records:
                if isinstance(rec, Message):
                    if rec.channel_id not in skip:
                        n += 1
                elif isinstance(rec, Channel) and rec.topic.startswith(skip_prefix):
                    skip.add(rec.id)
