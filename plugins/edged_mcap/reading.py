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
need them, and `edged recover` writes new ones.
"""

from __future__ import annotations

import io
import os
import struct
import zlib
from dataclasses import dataclass, field
from typing import IO, Callable, Iterator

from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
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

__all__ = ["ReadReport", "NoRecords", "iter_records", "iter_messages", "messages_after", "MAGIC", "MAX_RECORD"]

MAGIC = b"\x89MCAP0\r\n"

#: The largest record, and the largest uncompressed chunk, that is read (bytes). The
#: recorder writes chunks of at most 1 MiB; other writers' chunks are a few MiB.
MAX_RECORD = 1 << 30

#: Bytes read (or decompressed) at a time: what a length beyond the end costs at most.
_STEP = 1 << 20

#: Reasons kept per kind of damage (the counts go on).
_KEEP_ERRORS = 10


class NoRecords(McapError):
    """A file that starts with the MCAP magic but holds not one readable record.

    `reason` completes "the file ...", e.g. "holds only the MCAP magic", so that a
    caller can name the file: f"no records: {path} {exc.reason}".
    """

    def __init__(self, reason: str) -> None:
        super().__init__(f"no records: the file {reason}")
        self.reason = reason


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
    #: Why reading stopped before the end ("damaged: ..." for a length that cannot
    #: be true); None when it did not.
    error: str | None = None
    bad_chunk_errors: list[str] = field(default_factory=list)
    #: Records outside chunks (schema, channel, message, metadata, attachment, header)
    #: read whole but not parseable: skipped, reading goes on after them.
    bad_records: int = 0
    bad_record_errors: list[str] = field(default_factory=list)

    @property
    def damaged(self) -> bool:
        """Something was skipped or reading stopped on damage (not mere truncation)."""
        return bool(self.bad_chunks or self.bad_records or self.error)

    @property
    def healthy(self) -> bool:
        return self.finished and not self.damaged

    @property
    def unfinished_why(self) -> str:
        """Why reading ended before a footer, in words (for every command's message)."""
        return self.error or ("ends inside a record" if self.truncated else "has no footer")


class _Damage(ValueError):
    """A record that cannot be what its fields say (the reason)."""


class _Body(ReadDataStream):
    """Fields of one record parsed from its own bytes: reading past them is an error.

    The `mcap` record classes read their length-prefixed fields from the stream they
    are given; over the record's bytes (not the file) a length field that lies can
    only fail, never allocate.
    """

    def __init__(self, data: bytes) -> None:
        super().__init__(io.BytesIO(data))
        self._size = len(data)

    def read(self, length: int) -> bytes:
        if length == 0:
            return b""
        left = self._size - self._count
        if not 0 < length <= left:
            raise _Damage(f"a field of {length} bytes at record byte {self._count}, {left} remain")
        self._count += length
        return self._stream.read(length)


def _read(stream: IO[bytes], n: int) -> bytes:
    """Up to `n` bytes (fewer only at the end), never allocating much more than read."""
    if n <= _STEP:
        first = stream.read(n)
        if len(first) == n or not first:
            return first
        parts = [first]
        left = n - len(first)
    else:
        parts = []
        left = n
    while left > 0:
        b = stream.read(min(left, _STEP))
        if not b:
            break
        parts.append(b)
        left -= len(b)
    return b"".join(parts)


def _name(opcode: int) -> str:
    try:
        return Opcode(opcode).name
    except ValueError:
        return f"unknown (opcode 0x{opcode:02x})"


# -- chunks -----------------------------------------------------------------------------
#: Chunks that inflate to at most this are decompressed whole, checked, then read. A
#: larger chunk (the recorder writes 1 MiB ones; another writer may claim up to
#: `max_record`) is read twice in pieces: once to check its size, CRC and records without
#: keeping them, once to hand them out. What is held at once is then a piece and the
#: record being read, however much the chunk inflates to.
INFLATE_WHOLE = 16 << 20


def _pieces(read: Callable[[int], bytes], size: int) -> Iterator[bytes]:
    """The decompressed output in pieces of at most `_STEP`; `size` bytes in all or `_Damage`."""
    total = 0
    while True:
        b = read(min(_STEP, size + 1 - total))
        if not b:
            break
        total += len(b)
        if total > size:
            raise _Damage(f"decompresses to more than its declared {size} bytes")
        yield b
    if total != size:
        raise _Damage(f"decompresses to {total} bytes, not its declared {size}")


def _zstd(data: bytes, size: int) -> Iterator[bytes]:
    import zstandard

    with zstandard.ZstdDecompressor().stream_reader(data) as r:
        yield from _pieces(r.read, size)


def _lz4(data: bytes, size: int) -> Iterator[bytes]:
    import lz4.frame

    d = lz4.frame.LZ4FrameDecompressor()
    pending = [data]

    def read(n: int) -> bytes:
        if d.eof:
            return b""
        src = pending.pop() if pending else b""
        out: bytes = d.decompress(src, max_length=n)
        if not out and not src and d.needs_input:
            raise _Damage("lz4 data ends early")
        return out

    yield from _pieces(read, size)


def _stored(data: bytes, size: int) -> Iterator[bytes]:
    if len(data) != size:
        raise _Damage(f"holds {len(data)} bytes, not its declared {size}")
    yield data


_DECOMPRESS: dict[str, Callable[[bytes, int], Iterator[bytes]]] = {"zstd": _zstd, "lz4": _lz4, "": _stored}


def _inflate(chunk: Chunk, max_record: int) -> Iterator[bytes]:
    """The chunk's records' bytes in pieces, checked against its declared size and CRC."""
    size = chunk.uncompressed_size
    if size > max_record:
        raise _Damage(f"declares {size} bytes uncompressed (limit {max_record})")
    decompress = _DECOMPRESS.get(chunk.compression)
    if decompress is None:
        raise _Damage(f"unsupported compression {chunk.compression!r}")
    crc = 0
    for piece in decompress(chunk.data, size):
        crc = zlib.crc32(piece, crc)
        yield piece
    if chunk.uncompressed_crc != 0 and crc != chunk.uncompressed_crc:
        raise _Damage(f"CRC {crc:#010x} instead of {chunk.uncompressed_crc:#010x}")


_MESSAGE_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_RECORD_HEAD = struct.Struct("<BQ")


def _complete(data: bytes | bytearray, pos: int, out: list[McapRecord] | None) -> int:
    """Parse the complete records of `data` from `pos` on (into `out`, or only check
    them when None); the offset of the first record that is not complete."""
    end = len(data)
    head = _RECORD_HEAD.size
    while end - pos >= head:
        opcode, length = _RECORD_HEAD.unpack_from(data, pos)
        start = pos + head
        stop = start + length
        if stop > end:
            break
        if opcode == Opcode.MESSAGE:
            if length < _MESSAGE_HEAD.size:
                raise _Damage(f"MESSAGE record at chunk byte {pos} is {length} bytes long")
            if out is not None:
                channel_id, sequence, log_time, publish_time = _MESSAGE_HEAD.unpack_from(data, start)
                out.append(Message(channel_id, log_time, bytes(data[start + _MESSAGE_HEAD.size : stop]),
                                   publish_time, sequence))
        elif opcode == Opcode.CHANNEL:
            rec: McapRecord = Channel.read(_Body(bytes(data[start:stop])))
            if out is not None:
                out.append(rec)
        elif opcode == Opcode.SCHEMA:
            rec = Schema.read(_Body(bytes(data[start:stop])))
            if out is not None:
                out.append(rec)
        pos = stop
    return pos


def _cut(data: bytes | bytearray, pos: int, offset: int) -> _Damage:
    """The damage of a chunk whose data ends inside the record at `pos`."""
    end = len(data)
    head = _RECORD_HEAD.size
    if end - pos < head:
        return _Damage(f"a record header is cut at chunk byte {offset + pos}")
    opcode, length = _RECORD_HEAD.unpack_from(data, pos)
    return _Damage(f"{_name(opcode)} record at chunk byte {offset + pos} claims {length} bytes, "
                   f"{end - pos - head} remain")


def _walk(chunk: Chunk, max_record: int, keep: bool) -> Iterator[list[McapRecord]]:
    """The chunk's records, a list per piece of data (empty lists when not `keep`).

    Only the bytes of the record that spans two pieces are carried over: a piece and
    that record is what is held at once.
    """
    carry = bytearray()
    offset = 0  # chunk byte of carry[0]
    for piece in _inflate(chunk, max_record):
        if carry:
            carry += piece
            data: bytes | bytearray = carry
        else:
            data = piece
        out: list[McapRecord] | None = [] if keep else None
        pos = _complete(data, 0, out)
        offset += pos
        if data is carry:
            del carry[:pos]  # a record that grows over many pieces is not copied again
        elif pos < len(data):
            carry = bytearray(memoryview(data)[pos:])
        yield out or []
    if carry:
        raise _cut(carry, 0, offset)


def _chunk_records(chunk: Chunk, report: ReadReport, max_record: int) -> Iterator[McapRecord]:
    """The records of a chunk that reads whole; a damaged one is counted and skipped.

    A chunk that inflates to at most `INFLATE_WHOLE` is read once and kept until checked;
    a larger one is checked by a first reading that keeps nothing (twice the inflating,
    a bounded memory).
    """
    whole = chunk.uncompressed_size <= INFLATE_WHOLE
    try:
        if whole:
            kept = [r for part in _walk(chunk, max_record, keep=True) for r in part]
        else:
            for _ in _walk(chunk, max_record, keep=False):
                pass
    except Exception as exc:  # CRC, decompression, a broken record inside: skip the chunk
        _bad_chunk(report, exc)
        return
    report.chunks += 1
    if whole:
        yield from kept
        return
    try:
        for part in _walk(chunk, max_record, keep=True):
            yield from part
    except Exception as exc:  # not after a first reading that passed; counted if ever
        _bad_chunk(report, exc)


def _bad_chunk(report: ReadReport, exc: Exception) -> None:
    report.bad_chunks += 1
    if len(report.bad_chunk_errors) < _KEEP_ERRORS:
        why = str(exc) if isinstance(exc, _Damage) else f"{type(exc).__name__}: {exc}"
        report.bad_chunk_errors.append(why)


# -- records of the file ----------------------------------------------------------------
#: opcode -> parser of the record's bytes. The records read front to back need: the
#: indexes and statistics of the summary are skipped unparsed (`recover` rebuilds them).
_PARSE: dict[int, Callable[[bytes], McapRecord]] = {
    Opcode.HEADER: lambda b: Header.read(_Body(b)),
    Opcode.FOOTER: lambda b: Footer.read(_Body(b)),
    Opcode.SCHEMA: lambda b: Schema.read(_Body(b)),
    Opcode.CHANNEL: lambda b: Channel.read(_Body(b)),
    Opcode.MESSAGE: lambda b: Message.read(_Body(b), len(b)),
    Opcode.CHUNK: lambda b: Chunk.read(_Body(b)),
    Opcode.ATTACHMENT: lambda b: Attachment.read(_Body(b)),
    Opcode.METADATA: lambda b: Metadata.read(_Body(b)),
    Opcode.DATA_END: lambda b: DataEnd.read(_Body(b)),
}


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
    magic = _read(stream, len(MAGIC))
    if magic != MAGIC:
        if magic and MAGIC.startswith(magic):
            raise McapError("not an MCAP file (too short)")
        raise McapError("not a valid MCAP file (it does not begin with the MCAP magic)")
    header, pos = _first_record(stream, max_record)
    yield header
    head_size = _RECORD_HEAD.size
    while True:
        head = _read(stream, head_size)
        if len(head) < head_size:
            report.truncated = True
            return
        opcode, length = _RECORD_HEAD.unpack(head)
        if length > max_record:
            report.error = f"damaged: {_name(opcode)} record at byte {pos} claims {length} bytes (limit {max_record})"
            return
        body = _read(stream, length)
        if len(body) < length:
            report.truncated = True
            return
        at = pos
        pos += head_size + length
        parse = _PARSE.get(opcode)
        if parse is None:  # indexes, statistics, records of a later MCAP version
            continue
        try:
            rec = parse(body)
        except Exception as exc:  # its fields do not fit its bytes
            if opcode == Opcode.CHUNK:
                _bad_chunk(report, _Damage(f"CHUNK record at byte {at}: {_why(exc)}"))
            else:
                report.bad_records += 1
                if len(report.bad_record_errors) < _KEEP_ERRORS:
                    report.bad_record_errors.append(f"{_name(opcode)} record at byte {at}: {_why(exc)}")
            continue
        if isinstance(rec, Chunk):
            for r in _chunk_records(rec, report, max_record):
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
            tail = _read(stream, len(MAGIC))
            if len(tail) < len(MAGIC):
                report.truncated = True
            elif tail != MAGIC:
                report.error = f"damaged: the footer at byte {at} is not followed by the MCAP magic"
            return


def _first_record(stream: IO[bytes], max_record: int) -> tuple[Header, int]:
    """The header every MCAP file begins with, and the offset after it; `NoRecords`
    when the file holds only the magic, ends inside its first record, or does not begin
    with a header at all (so that it is refused as an empty file is)."""
    at = len(MAGIC)
    head = _read(stream, _RECORD_HEAD.size)
    if not head:
        raise NoRecords("holds only the MCAP magic")
    if len(head) < _RECORD_HEAD.size:
        raise NoRecords("ends inside its first record")
    opcode, length = _RECORD_HEAD.unpack(head)
    if opcode != Opcode.HEADER:
        raise NoRecords(f"begins with a {_name(opcode)} record, not the MCAP header")
    if length > max_record:
        raise NoRecords(f"is damaged: its header claims {length} bytes (limit {max_record})")
    body = _read(stream, length)
    if len(body) < length:
        raise NoRecords("ends inside its first record")
    try:
        header = Header.read(_Body(body))
    except Exception as exc:  # its fields do not fit its bytes
        raise NoRecords(f"is damaged: its header at byte {at}: {_why(exc)}") from None
    return header, at + _RECORD_HEAD.size + length


def _why(exc: BaseException) -> str:
    if isinstance(exc, _Damage):
        return str(exc)
    if isinstance(exc, (EndOfFile, struct.error)):
        return "its fields run past its length"
    return f"{type(exc).__name__}: {exc}"


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
    head_size = _RECORD_HEAD.size
    with open(path, "rb") as stream:
        stream.seek(offset)
        while True:
            head = _read(stream, head_size)
            if len(head) < head_size:
                return n
            opcode, length = _RECORD_HEAD.unpack(head)
            if length > MAX_RECORD:
                return n
            body = _read(stream, length)
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
                records = _chunk_records(chunk, report, MAX_RECORD)  # type: ignore[arg-type]
            else:
                continue
            for rec in records:
                if isinstance(rec, Message):
                    if rec.channel_id not in skip:
                        n += 1
                elif isinstance(rec, Channel) and rec.topic.startswith(skip_prefix):
                    skip.add(rec.id)
