"""What every reading of an MCAP file shares: the report of how it read, the damage it
met, and bytes read without trusting a length field (`reading`'s rules).

`Body` parses a record's fields from its own bytes only: a length field that lies can
only fail there, never allocate; `read_up_to` reads a length in pieces, so that a length
beyond the end of the file costs what the file holds.
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass, field
from typing import IO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode

__all__ = [
    "KEEP_ERRORS",
    "MESSAGE_HEAD",
    "RECORD_HEAD",
    "STEP",
    "Body",
    "Damage",
    "NoRecords",
    "ReadReport",
    "bad_chunk",
    "opcode_name",
    "read_up_to",
    "why",
]

#: Bytes read (or decompressed) at a time: what a length beyond the end costs at most.
STEP = 1 << 20

#: Reasons kept per kind of damage (the counts go on).
KEEP_ERRORS = 10

RECORD_HEAD = struct.Struct("<BQ")  # opcode, length
MESSAGE_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time


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


class Damage(ValueError):
    """A record that cannot be what its fields say (the reason)."""


class Body(ReadDataStream):
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
            raise Damage(f"a field of {length} bytes at record byte {self._count}, {left} remain")
        self._count += length
        return self._stream.read(length)


def read_up_to(stream: IO[bytes], n: int) -> bytes:
    """Up to `n` bytes (fewer only at the end), never allocating much more than read."""
    if n <= STEP:
        first = stream.read(n)
        if len(first) == n or not first:
            return first
        parts = [first]
        left = n - len(first)
    else:
        parts = []
        left = n
    while left > 0:
        b = stream.read(min(left, STEP))
        if not b:
            break
        parts.append(b)
        left -= len(b)
    return b"".join(parts)


def opcode_name(opcode: int) -> str:
    """The record type an opcode names, for a message ("CHUNK", "unknown (opcode 0x42)")."""
    try:
        return Opcode(opcode).name
    except ValueError:
        return f"unknown (opcode 0x{opcode:02x})"


def why(exc: BaseException) -> str:
    """Why a record's fields did not parse, in words."""
    if isinstance(exc, Damage):
        return str(exc)
    if isinstance(exc, (EndOfFile, struct.error)):
        return "its fields run past its length"
    return f"{type(exc).__name__}: {exc}"


def bad_chunk(report: ReadReport, exc: Exception) -> None:
    """Count a chunk skipped for `exc` (and keep the reason, up to `KEEP_ERRORS`)."""
    report.bad_chunks += 1
    if len(report.bad_chunk_errors) < KEEP_ERRORS:
        reason = str(exc) if isinstance(exc, Damage) else f"{type(exc).__name__}: {exc}"
        report.bad_chunk_errors.append(reason)
