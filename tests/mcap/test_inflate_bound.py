"""A chunk that inflates to far more than it holds costs a bounded memory (issue 32).

94 KB on disk can declare chunks of nearly 1 GiB each; `inspect`, `replay`, `recover`
and `export` held each whole (and a copy of it) at once: 3.9 GB RSS for two such
chunks. A chunk larger than `INFLATE_WHOLE` is now read in pieces, twice: a first
reading checks its size, CRC and records and keeps nothing, the second hands them out.
These tests read such chunks at several sizes and count what Python holds meanwhile.
"""

from __future__ import annotations

import io
import struct
import tracemalloc
import zlib
from typing import Any, Callable, Iterator

import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Schema

from edged_mcap import chunks
from edged_mcap.reading import MAGIC, ReadReport, iter_messages

_MIB = 1 << 20
_PAYLOAD = 4000  # bytes of each message's data
_NS = 1_732_350_000 * 10**9


def _message(seq: int, size: int = _PAYLOAD) -> bytes:
    b = RecordBuilder()
    data = (b"%08d" % seq) * (size // 8)
    Message(channel_id=1, log_time=_NS + seq, data=data, publish_time=_NS + seq, sequence=seq).write(b)
    return b.end()


def _records(n: int, big_at: int | None = None, big: int = 0) -> Iterator[bytes]:
    for seq in range(n):
        yield _message(seq, big if seq == big_at else _PAYLOAD)


def _chunk(parts: Callable[[], Iterator[bytes]], *, crc_delta: int = 0, cut: int = 0) -> bytes:
    """One zstd chunk record of the parts, streamed through the compressor (never whole)."""
    size = 0
    crc = 0
    c = zstandard.ZstdCompressor(level=1).compressobj()
    out: list[bytes] = []
    pending = b""
    for part in parts():
        if pending:
            out.append(c.compress(pending))
            crc = zlib.crc32(pending, crc)
            size += len(pending)
        pending = part
    pending = pending[: len(pending) - cut] if cut else pending  # a record that ends early
    out.append(c.compress(pending))
    crc = zlib.crc32(pending, crc)
    size += len(pending)
    out.append(c.flush())
    b = RecordBuilder()
    Chunk(compression="zstd", data=b"".join(out), message_start_time=_NS, message_end_time=_NS,
          uncompressed_crc=(crc + crc_delta) & 0xFFFFFFFF, uncompressed_size=size).write(b)
    return b.end()


def _file(*chunks: bytes) -> bytes:
    b = RecordBuilder()
    Header(profile="", library="test").write(b)
    Schema(id=1, name="s", encoding="jsonschema", data=b"{}").write(b)
    Channel(id=1, topic="/t", message_encoding="json", metadata={}, schema_id=1).write(b)
    head = b.end()
    DataEnd(data_section_crc=0).write(b)
    Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(b)
    return MAGIC + head + b"".join(chunks) + b.end() + MAGIC


def _count(data: bytes) -> tuple[list[int], list[int], ReadReport]:
    """Sequences and payload sizes of the messages read (kept as ints, not payloads)."""
    report = ReadReport()
    seqs: list[int] = []
    sizes: list[int] = []
    for _ch, _s, m in iter_messages(io.BufferedReader(io.BytesIO(data), 1 << 16), report):
        seqs.append(m.sequence)
        sizes.append(len(m.data))
        assert m.data[:8] == b"%08d" % m.sequence
    return seqs, sizes, report


def _peak(fn: Callable[[], Any]) -> tuple[Any, int]:
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        before = tracemalloc.get_traced_memory()[0]
        out = fn()
        return out, tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("mib", [20, 48, 96])
def test_a_chunk_inflating_far_beyond_its_size_is_read_whole_in_bounded_memory(mib):
    n = mib * _MIB // (_PAYLOAD + 40)
    chunk = _chunk(lambda: _records(n))
    assert len(chunk) < mib * _MIB // 50  # a small file that inflates
    data = _file(chunk, chunk)
    (seqs, _sizes, report), peak = _peak(lambda: _count(data))
    assert seqs == list(range(n)) * 2  # every message of both chunks, in order
    assert report.chunks == 2 and report.healthy
    # Held at once: the file, a piece of the inflated chunk, the one record across two
    # pieces, and the ints counted here; never the inflated chunk.
    assert peak < len(data) + 4 * _MIB + 120 * len(seqs), f"{peak / _MIB:.1f} MiB for {mib} MiB chunks"


def test_the_pieces_read_what_a_whole_chunk_reads(monkeypatch):
    n = 5000
    data = _file(_chunk(lambda: _records(n, big_at=77, big=3 * _MIB + 5)))  # a record over 4 pieces
    streamed = _count(data)
    monkeypatch.setattr(chunks, "INFLATE_WHOLE", 1 << 30)
    whole = _count(data)
    assert streamed[0] == whole[0] == list(range(n))
    assert streamed[1] == whole[1] and streamed[1][77] == 3 * _MIB + 5 - (3 * _MIB + 5) % 8
    assert streamed[2].chunks == whole[2].chunks == 1


@pytest.mark.parametrize("mib", [20, 64])
@pytest.mark.parametrize("damage", ["crc", "cut"])
def test_a_large_damaged_chunk_gives_nothing_and_is_counted_in_bounded_memory(mib, damage):
    n = mib * _MIB // (_PAYLOAD + 40)
    good = _chunk(lambda: _records(100))
    if damage == "crc":
        bad = _chunk(lambda: _records(n), crc_delta=1)
    else:
        bad = _chunk(lambda: _records(n), cut=10)
    data = _file(good, bad, good)
    (seqs, _sizes, report), peak = _peak(lambda: _count(data))
    assert seqs == list(range(100)) * 2  # the good chunks on either side, none of the bad
    assert report.chunks == 2 and report.bad_chunks == 1 and report.finished
    why = report.bad_chunk_errors[0]
    assert ("CRC" in why) if damage == "crc" else ("MESSAGE record at chunk byte" in why and "remain" in why)
    assert peak < len(data) + 4 * _MIB


def test_a_large_chunk_that_inflates_beyond_what_it_declares_stops_at_the_declared_size():
    n = 40 * _MIB // (_PAYLOAD + 40)
    chunk = bytearray(_chunk(lambda: _records(n)))
    # The chunk's uncompressed_size field (after opcode, length, start and end times).
    declared = struct.unpack_from("<Q", chunk, 9 + 16)[0]
    struct.pack_into("<Q", chunk, 9 + 16, declared - 4000 * 1024)
    data = _file(bytes(chunk))
    (seqs, _sizes, report), peak = _peak(lambda: _count(data))
    assert seqs == [] and report.bad_chunks == 1
    assert "more than its declared" in report.bad_chunk_errors[0]
    assert peak < len(data) + 4 * _MIB
