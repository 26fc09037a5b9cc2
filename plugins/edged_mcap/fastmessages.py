"""Adding a message to the open chunk of an `mcap` Writer, without the per-message objects.

`Writer.add_message` builds a `Message` record object and writes its six fields through
six `struct.pack` calls: about 5 µs per message, the largest single cost of a fast replay
(two or three messages per NMEA sentence). This does the same bookkeeping (statistics,
the chunk's time span and message index) and writes the record with one `pack`; the
chunk is closed, compressed and indexed by the Writer itself.

The chunk's message indexes are `PackedMessageIndex`es: the same record, written with
one `pack` for all its entries instead of two calls per entry (the Writer writes every
index of every chunk: a tenth of the recorder's time with the library's loop).

It reaches into the Writer's private state, so it is used only when that state looks
exactly as written for (`attach` returns None otherwise and the caller keeps using
`add_message`); a test checks that both ways give the same file, byte for byte.
"""

from __future__ import annotations

import struct
from itertools import chain
from typing import Any, Callable

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

__all__ = ["FastMessages", "PackedMessageIndex"]

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
