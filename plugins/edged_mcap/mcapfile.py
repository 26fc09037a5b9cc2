"""One MCAP file being written: the `mcap` Writer plus lazily registered channels."""

from __future__ import annotations

import io
import os
import stat
from pathlib import Path
from typing import BinaryIO

from mcap.writer import CompressionType, Writer

from .fastmessages import FastMessages, PackedChunkIndexes
from edged.schemas import MESSAGE_ENCODING, SCHEMA_ENCODING, schema_bytes

__all__ = ["McapFile", "COMPRESSION"]

COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


class McapFile:
    """A file open for recording; every method may raise OSError (the caller decides)."""

    def __init__(
        self,
        stream: BinaryIO,
        path: Path,
        *,
        compression: str,
        chunk_size: int,
        library: str,
        metadata: dict[str, str],
    ) -> None:
        self.path = path
        if isinstance(stream, io.RawIOBase):
            # The mcap Writer would buffer a raw stream itself, out of reach of our
            # flush and close: buffer it here so that flush() really flushes.
            stream = io.BufferedWriter(stream)
        self.stream = stream
        self._chunk_size = chunk_size
        #: (device, inode) of the file on disk, when the stream is one: what allows
        #: removing a file that holds nothing, and never another file of that name.
        self._ident = _identity(stream)
        self._schemas: dict[str, int] = {}
        #: topic -> channel id of the channels registered so far (read by the recorder's
        #: loop directly: one dictionary look-up per message instead of a call).
        self.channels: dict[str, int] = {}
        self._writer = Writer(stream, chunk_size=chunk_size, compression=COMPRESSION[compression])
        self._library = library
        self._metadata = metadata
        #: Bytes of the header and metadata: a file no longer than this holds no data.
        self.header_size = 0
        PackedChunkIndexes.attach(self._writer)  # 200 bytes per chunk held, not 1.4 KB
        fast = FastMessages.attach(self._writer)
        #: add_message(channel_id, log_ns, data, pub_ns): the fast path when it applies.
        self.add_message = fast.add if fast is not None else self._writer.add_message
        #: add_batch([(channel_id, log_ns, data), ...], pub_ns): all of them, in order.
        self.add_batch = fast.add_batch if fast is not None else self._add_each

    def _add_each(self, messages: list[tuple[int, int, bytes]], publish_time: int) -> int:
        add = self._writer.add_message
        for i, (cid, log, data) in enumerate(messages):
            try:
                add(cid, log, data, publish_time)
            except Exception as exc:
                exc.added = i  # type: ignore[attr-defined]
                raise
        return len(messages)

    def start(self) -> None:
        """Write the header and metadata, and push them out at once: a disk without
        room fails here, while the file holds nothing (the caller then `abandon()`s and
        `remove_if_empty(header_only=False)`), rather than at the first flush."""
        self._writer.start(profile="", library=self._library)
        self._writer.add_metadata("edged", self._metadata)
        self.stream.flush()
        self.header_size = self.stream.tell()

    def channel(self, topic: str, schema: str) -> int:
        """The channel id of `topic`, registering topic and schema on first use."""
        cid = self.channels.get(topic)
        if cid is None:
            sid = self._schemas.get(schema)
            if sid is None:
                sid = self._writer.register_schema(schema, SCHEMA_ENCODING, schema_bytes(schema))
                self._schemas[schema] = sid
            cid = self._writer.register_channel(topic, MESSAGE_ENCODING, sid)
            self.channels[topic] = cid
        return cid

    def add(self, topic: str, schema: str, data: bytes, log_ns: int, pub_ns: int) -> None:
        cid = self.channels.get(topic)
        if cid is None:
            cid = self.channel(topic, schema)
        self.add_message(cid, log_ns, data, pub_ns)

    @property
    def index_entries(self) -> int:
        """Chunks indexed so far: the Writer keeps one ChunkIndex per chunk in memory
        until `finish()`, the only part of a file being written that grows with its
        length (the recorder starts a new file before it grows too long)."""
        held = getattr(self._writer, "_Writer__chunk_indices", None)
        if held is not None:
            return len(held)
        return self.stream.tell() // max(1, self._chunk_size // 4)  # the Writer changed: a bound

    @property
    def size(self) -> int:
        """Bytes written so far (the open chunk, at most a chunk size, not included)."""
        return self.stream.tell()

    def flush(self, fsync: bool) -> None:
        """Close the open chunk and push it to the disk: what a crash can no longer take."""
        self._writer.flush()
        if fsync:
            try:
                fd = self.stream.fileno()
            except (AttributeError, io.UnsupportedOperation):  # an in-memory stream
                return
            os.fsync(fd)

    def finish(self) -> None:
        """Write the summary (indexes, statistics) and close."""
        try:
            self._writer.finish()
            self.stream.flush()
        finally:
            self.stream.close()

    def abandon(self) -> None:
        """Close without the summary after a write error; `edged recover` repairs it."""
        try:
            self.stream.close()
        except (OSError, ValueError):
            pass  # the data already written stays; the buffered rest is what was lost

    def remove_if_empty(self, header_only: bool = True) -> bool:
        """After `abandon()`: delete the file when it holds no complete chunk (nothing
        but its header, perhaps the start of a chunk a full disk cut short), which no
        reader accepts and nothing needs. True when deleted. `header_only=False`:
        delete it whatever it holds (a file whose header could not be written)."""
        if self._ident is None:
            return False  # not a file of ours on disk (a test's stream)
        try:
            st = os.stat(self.path)
            if not stat.S_ISREG(st.st_mode):
                return False  # a device, a FIFO (`--record /dev/full`): never ours to delete
            if (st.st_dev, st.st_ino) != self._ident:
                return False  # the name now belongs to another file
            if header_only and st.st_size >= self._first_chunk_end():
                return False  # data reached the disk: `edged recover` gets it back
            os.unlink(self.path)
        except OSError:
            return False
        return True

    def _first_chunk_end(self) -> int:
        """Where the first chunk record ends in the file (a file this long holds data)."""
        held = getattr(self._writer, "_Writer__chunk_indices", None)
        if not held:
            # No chunk completed yet, or the Writer changed: past the header is data.
            return self.header_size + (1 if held is None else 1 << 62)
        first = held[0]
        try:
            return int(first.chunk_start_offset) + int(first.chunk_length)
        except (AttributeError, TypeError, ValueError):
            return self.header_size + 1


def _identity(stream: BinaryIO) -> tuple[int, int] | None:
    try:
        st = os.fstat(stream.fileno())
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        return None
    if not stat.S_ISREG(st.st_mode):
        return None  # a device or a FIFO is never a file of ours to remove
    return (st.st_dev, st.st_ino)
