"""Adding a message to the open chunk of an `mcap` Writer, without the per-message objects.

`Writer.add_message` builds a `Message` record object and writes its six fields through
six `struct.pack` calls: about 5 µs per message, the largest single cost of a fast replay
(two or three messages per NMEA sentence). This does the same bookkeeping (statistics,
the chunk's time span and message index) and writes the record with one `pack`; the
chunk is closed, compressed and indexed by the Writer itself.

The chunk's message indexes are `PackedMessageIndex`es: the same record, written with
one `pack` for all its entries instead of two calls per entry (the Writer writes every
index of every chunk: a tenth of the recorder's time with the library's loop).

The Writer keeps one `ChunkIndex` object per chunk until `finish()` (a dataclass with a
dict of message index offsets: about 1.4 KB with a dozen channels, 15 MB per hour of
the reference load). `PackedChunkIndexes` takes the place of its list and keeps each
entry as the bytes of the record `finish()` writes (about 200 bytes).

It reaches into the Writer's private state, so it is used only when that state looks
exactly as written for (`attach` returns None otherwise and the caller keeps using
`add_message`; `PackedChunkIndexes.attach` returns False and the list stays); a test
checks that both ways give the same file, byte for byte.
"""

from __future__ import annotations

import struct
from itertools import chain
from typing import Any, Callable, Iterator

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import ChunkIndex, MessageIndex
from mcap.writer import Writer

__all__ = ["FastMessages", "PackedMessageIndex", "PackedChunkIndexes"]

_OPCODE_MESSAGE = 0x05
_HEAD = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log, publish
_FIXED = _HEAD.size - 9  # the record length counts what follows opcode and length


class PackedMessageIndex(MessageIndex):
    """A MessageIndex that writes its (log time, offset) entries with one `pack`."""

    def write(self, stream: RecordBuilder) -> None:
        records = self.records
        stream.start_record(Opcode.MESSAGE_INDEX)
        stream.write(struct.pack(f"<HI{2 * len(records)}Q", self.channel_id, 16 * len(records),
                                 *chain.from_iterable(records)))
        stream.finish_record()


class _Records:
    """Serialized records that write themselves into a RecordBuilder as they are."""

    __slots__ = ("data",)

    def __init__(self, data: bytes | bytearray) -> None:
        self.data = data

    def write(self, stream: RecordBuilder) -> None:
        stream.write(self.data)


class PackedChunkIndexes:
    """The Writer's chunk index list, holding each ChunkIndex as its record's bytes.

    The Writer only appends to the list (once per chunk) and iterates over it in
    `finish()`, calling `write()` on each entry: here that is one entry writing all the
    records at once. `len()` is the number of chunks; `[0]` the first chunk's index
    (its offsets tell where the file's first complete chunk ends).
    """

    __slots__ = ("_data", "_n", "_first")

    _MANGLED = "_Writer__chunk_indices"

    def __init__(self) -> None:
        self._data = bytearray()
        self._n = 0
        self._first: ChunkIndex | None = None

    @classmethod
    def attach(cls, writer: Writer) -> bool:
        """Put a PackedChunkIndexes in place of `writer`'s list; False when it is not
        the known (empty) list, which then stays."""
        held = getattr(writer, cls._MANGLED, None)
        if held.__class__ is not list or held:
            return False
        setattr(writer, cls._MANGLED, cls())
        return True

    def append(self, index: ChunkIndex) -> None:
        b = RecordBuilder()
        index.write(b)
        self._data += b.end()
        if self._first is None:
            self._first = index
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i: int) -> ChunkIndex:
        if self._n and i in (0, -self._n):
            assert self._first is not None
            return self._first
        raise IndexError("only the first chunk index is kept as an object")

    def __iter__(self) -> Iterator[_Records]:
        if self._n:
            yield _Records(self._data)  # no copy: the summary builder copies it once

    @property
    def nbytes(self) -> int:
        return len(self._data)


def _count_stretch(stats: Any, chunk: Any, k: int, lo: int, hi: int) -> None:
    """The file's statistics and the chunk's after `k` messages logged from `lo` to
    `hi` (ns) were added to it (once per stretch, not per message)."""
    if stats.message_count == 0 or lo < stats.message_start_time:
        stats.message_start_time = lo
    if hi > stats.message_end_time:
        stats.message_end_time = hi
    stats.message_count += k
    if chunk.num_messages == 0 or lo < chunk.message_start_time:
        chunk.message_start_time = lo
    if hi > chunk.message_end_time:
        chunk.message_end_time = hi
    chunk.num_messages += k


class FastMessages:
    """`add(channel_id, log_ns, data, pub_ns)` equivalent to `writer.add_message`."""

    __slots__ = ("_stats", "_chunk", "_chunk_size", "_finalize")

    def __init__(self, stats: Any, chunk: Any, chunk_size: int, finalize: Callable[[], None]) -> None:
        self._stats = stats
        self._chunk = chunk
        self._chunk_size = chunk_size
        self._finalize = finalize

    @classmethod
    def attach(cls, writer: Writer) -> "FastMessages | None":
        """The fast path for `writer`, or None when its internals are not the known ones."""
        stats = getattr(writer, "_Writer__statistics", None)
        chunk = getattr(writer, "_Writer__chunk_builder", None)
        size = getattr(writer, "_Writer__chunk_size", None)
        finalize = getattr(writer, "_Writer__finalize_chunk", None)
        buf = getattr(getattr(chunk, "record_writer", None), "_buffer", None)
        known = (
            all(hasattr(stats, a) for a in ("message_count", "message_start_time", "message_end_time",
                                            "channel_message_counts"))
            and all(hasattr(chunk, a) for a in ("message_start_time", "message_end_time", "message_indices",
                                                "num_messages"))
            and isinstance(size, int)
            and callable(finalize)
            and callable(getattr(buf, "write", None))
            and callable(getattr(buf, "tell", None))
        )
        return cls(stats, chunk, size, finalize) if known else None

    def add_batch(self, messages: list[tuple[int, int, bytes]], publish_time: int) -> int:
        """`add(channel, log, data, publish_time)` for each of `messages` in order;
        returns how many were added. When closing a chunk raises, the exception
        carries as `added` the number of messages before the one whose add raised.

        The same bytes as one `add` per message: the records of a stretch are joined
        and written at once, their offsets counted instead of asked for, and the
        statistics updated once per stretch (a stretch ends where a chunk fills)."""
        pack = _HEAD.pack
        head = _HEAD.size
        stats = self._stats
        counts = stats.channel_message_counts
        limit = self._chunk_size
        n = len(messages)
        i = 0
        while i < n:
            chunk = self._chunk
            buf = chunk.record_writer._buffer  # replaced by a new BytesIO at each chunk end
            offset = buf.tell()
            indices = chunk.message_indices
            parts: list[bytes] = []
            start = i
            lo = hi = messages[i][1]
            while i < n:
                channel_id, log_time, data = messages[i]
                i += 1
                index = indices.get(channel_id)
                if index is None:
                    index = indices[channel_id] = PackedMessageIndex(channel_id=channel_id, records=[])
                index.records.append((log_time, offset))
                size = len(data)
                parts.append(pack(_OPCODE_MESSAGE, _FIXED + size, channel_id, 0, log_time, publish_time))
                parts.append(data)
                offset += head + size
                counts[channel_id] += 1
                if log_time < lo:
                    lo = log_time
                elif log_time > hi:
                    hi = log_time
                if offset > limit:
                    break
            buf.write(b"".join(parts))
            _count_stretch(stats, chunk, i - start, lo, hi)
            if offset > limit:
                try:
                    self._finalize()
                except Exception as exc:
                    # (as `add` one at a time: the message whose add closed the
                    # chunk that could not be written was not added)
                    exc.added = i - 1  # type: ignore[attr-defined]
                    raise
        return n

    def add(self, channel_id: int, log_time: int, data: bytes, publish_time: int) -> None:
        stats = self._stats
        if stats.message_count == 0 or log_time < stats.message_start_time:
            stats.message_start_time = log_time
        if log_time > stats.message_end_time:
            stats.message_end_time = log_time
        stats.channel_message_counts[channel_id] += 1
        stats.message_count += 1

        chunk = self._chunk
        if chunk.num_messages == 0 or log_time < chunk.message_start_time:
            chunk.message_start_time = log_time
        if log_time > chunk.message_end_time:
            chunk.message_end_time = log_time
        buf = chunk.record_writer._buffer  # replaced by a new BytesIO at each chunk end
        offset = buf.tell()
        index = chunk.message_indices.get(channel_id)
        if index is None:
            index = chunk.message_indices[channel_id] = PackedMessageIndex(channel_id=channel_id, records=[])
        index.records.append((log_time, offset))
        chunk.num_messages += 1
        record = _HEAD.pack(_OPCODE_MESSAGE, _FIXED + len(data), channel_id, 0, log_time, publish_time) + data
        buf.write(record)
        if offset + len(record) > self._chunk_size:
            self._finalize()
