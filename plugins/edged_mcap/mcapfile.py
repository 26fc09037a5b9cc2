"""One MCAP file being written: the `mcap` Writer plus lazily registered channels."""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import BinaryIO

from mcap.writer import CompressionType, Writer

from .fastmessages import FastMessages
from .schemas import MESSAGE_ENCODING, SCHEMA_ENCODING, schema_bytes

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
        self._writer = Writer(stream, chunk_size=chunk_size, compression=COMPRESSION[compression])
        self._schemas: dict[str, int] = {}
        #: topic -> channel id of the channels registered so far (read by the recorder's
        #: loop directly: one dictionary look-up per message instead of a call).
        self.channels: dict[str, int] = {}
        self._writer.start(profile="", library=library)
        self._writer.add_metadata("edged", metadata)
        fast = FastMessages.attach(self._writer)
        #: add_message(channel_id, log_ns, data, pub_ns): the fast path when it applies.
        self.add_message = fast.add if fast is not None else self._writer.add_message

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
        except OSError:
            pass  # the data already written stays; the buffered rest is what was lost
