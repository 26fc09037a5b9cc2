"""The records of an MCAP chunk, checked before they are handed out (`reading`'s rules).

A chunk is decompressed only when its declared uncompressed size is within
`max_record`, and never into more than it declared; its CRC is checked; one that fails
any check is skipped whole and counted in the report (`ReadReport.bad_chunks`).
"""

from __future__ import annotations

import zlib
from typing import Callable, Iterator

from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, McapRecord, Message, Schema

from .readbase import MESSAGE_HEAD, RECORD_HEAD, STEP, Body, Damage, ReadReport, bad_chunk, opcode_name

__all__ = ["INFLATE_WHOLE", "chunk_records"]

#: Chunks that inflate to at most this are decompressed whole, checked, then read. A
#: larger chunk (the recorder writes 1 MiB ones; another writer may claim up to
#: `max_record`) is read twice in pieces: once to check its size, CRC and records without
#: keeping them, once to hand them out. What is held at once is then a piece and the
#: record being read, however much the chunk inflates to.
INFLATE_WHOLE = 16 << 20


def _pieces(read: Callable[[int], bytes], size: int) -> Iterator[bytes]:
    """The decompressed output in pieces of at most `STEP`; `size` bytes in all or `Damage`."""
    total = 0
    while True:
        b = read(min(STEP, size + 1 - total))
        if not b:
            break
        total += len(b)
        if total > size:
            raise Damage(f"decompresses to more than its declared {size} bytes")
        yield b
    if total != size:
        raise Damage(f"decompresses to {total} bytes, not its declared {size}")


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
            raise Damage("lz4 data ends early")
        return out

    yield from _pieces(read, size)


def _stored(data: bytes, size: int) -> Iterator[bytes]:
    if len(data) != size:
        raise Damage(f"holds {len(data)} bytes, not its declared {size}")
    yield data


_DECOMPRESS: dict[str, Callable[[bytes, int], Iterator[bytes]]] = {"zstd": _zstd, "lz4": _lz4, "": _stored}


def _inflate(chunk: Chunk, max_record: int) -> Iterator[bytes]:
    """The chunk's records' bytes in pieces, checked against its declared size and CRC."""
    size = chunk.uncompressed_size
    if size > max_record:
        raise Damage(f"declares {size} bytes uncompressed (limit {max_record})")
    decompress = _DECOMPRESS.get(chunk.compression)
    if decompress is None:
        raise Damage(f"unsupported compression {chunk.compression!r}")
    crc = 0
    for piece in decompress(chunk.data, size):
        crc = zlib.crc32(piece, crc)
        yield piece
    if chunk.uncompressed_crc != 0 and crc != chunk.uncompressed_crc:
        raise Damage(f"CRC {crc:#010x} instead of {chunk.uncompressed_crc:#010x}")


def _complete(data: bytes | bytearray, pos: int, out: list[McapRecord] | None) -> int:
    """Parse the complete records of `data` from `pos` on (into `out`, or only check
    them when None); the offset of the first record that is not complete."""
    end = len(data)
    head = RECORD_HEAD.size
    while end - pos >= head:
        opcode, length = RECORD_HEAD.unpack_from(data, pos)
        start = pos + head
        stop = start + length
        if stop > end:
            break
        if opcode == Opcode.MESSAGE:
            if length < MESSAGE_HEAD.size:
                raise Damage(f"MESSAGE record at chunk byte {pos} is {length} bytes long")
            if out is not None:
                channel_id, sequence, log_time, publish_time = MESSAGE_HEAD.unpack_from(data, start)
                out.append(Message(channel_id, log_time, bytes(data[start + MESSAGE_HEAD.size : stop]),
                                   publish_time, sequence))
        elif opcode == Opcode.CHANNEL:
            rec: McapRecord = Channel.read(Body(bytes(data[start:stop])))
            if out is not None:
                out.append(rec)
        elif opcode == Opcode.SCHEMA:
            rec = Schema.read(Body(bytes(data[start:stop])))
            if out is not None:
                out.append(rec)
        pos = stop
    return pos


def _cut(data: bytes | bytearray, pos: int, offset: int) -> Damage:
    """The damage of a chunk whose data ends inside the record at `pos`."""
    end = len(data)
    head = RECORD_HEAD.size
    if end - pos < head:
        return Damage(f"a record header is cut at chunk byte {offset + pos}")
    opcode, length = RECORD_HEAD.unpack_from(data, pos)
    return Damage(f"{opcode_name(opcode)} record at chunk byte {offset + pos} claims {length} bytes, "
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


def chunk_records(chunk: Chunk, report: ReadReport, max_record: int) -> Iterator[McapRecord]:
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
        bad_chunk(report, exc)
        return
    report.chunks += 1
    if whole:
        yield from kept
        return
    try:
        for part in _walk(chunk, max_record, keep=True):
            yield from part
    except Exception as exc:  # not after a first reading that passed; counted if ever
        bad_chunk(report, exc)
