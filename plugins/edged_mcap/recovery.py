"""Make an unfinished recording valid again (`edged recover FILE.mcap`).

Everything up to the last complete chunk is copied, record by record, into a new file
written by the `mcap` Writer, which adds the indexes and summary a power loss kept the
recorder from writing. The original is only ever read.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from .reading import ReadReport, iter_records

__all__ = ["RecoverResult", "recovered_path", "recover"]


@dataclass
class RecoverResult:
    output: Path
    report: ReadReport
    messages: int
    channels: int


def recovered_path(src: Path) -> Path:
    """`x.mcap` -> `x.recovered.mcap`, beside it."""
    stem = src.name[: -len(".mcap")] if src.name.endswith(".mcap") else src.name
    return src.with_name(f"{stem}.recovered.mcap")


class _Copier:
    """Re-registers schemas and channels under the new file's ids (each once)."""

    def __init__(self, writer: Writer) -> None:
        self.w = writer
        self.schemas: dict[int, int] = {}
        self.channels: dict[int, int] = {}
        self.messages = 0
        self.started = False

    def header(self, r: Header) -> None:
        if not self.started:
            self.w.start(profile=r.profile, library=r.library)
            self.started = True

    def schema(self, r: Schema) -> None:
        if r.id not in self.schemas:
            self.schemas[r.id] = self.w.register_schema(r.name, r.encoding, r.data)

    def channel(self, r: Channel) -> None:
        if r.id not in self.channels:
            sid = self.schemas.get(r.schema_id, 0)
            self.channels[r.id] = self.w.register_channel(r.topic, r.message_encoding, sid, dict(r.metadata))

    def message(self, r: Message) -> None:
        cid = self.channels.get(r.channel_id)
        if cid is not None:
            self.w.add_message(cid, r.log_time, r.data, r.publish_time, r.sequence)
            self.messages += 1

    def metadata(self, r: Metadata) -> None:
        self.w.add_metadata(r.name, dict(r.metadata))

    def attachment(self, r: Attachment) -> None:
        self.w.add_attachment(r.create_time, r.log_time, r.name, r.media_type, r.data)


_COPY = {
    Header: _Copier.header,
    Schema: _Copier.schema,
    Channel: _Copier.channel,
    Message: _Copier.message,
    Metadata: _Copier.metadata,
    Attachment: _Copier.attachment,
}


def recover(src: Path, dst: Path | None = None) -> RecoverResult:
    """Copy what `src` holds into `dst` (default `recovered_path(src)`), finished.

    Raises McapError when `src` is not MCAP and OSError when files cannot be used.
    The output appears atomically (written aside, then renamed).
    """
    dst = dst or recovered_path(src)
    if dst.resolve() == src.resolve():
        raise ValueError("the recovered file must not replace the original")
    tmp = dst.with_name(dst.name + ".part")
    report = ReadReport()
    try:
        with open(src, "rb") as fin, open(tmp, "wb") as fout:
            copier = _Copier(Writer(fout, compression=CompressionType.ZSTD))
            for rec in iter_records(fin, report):
                copy = _COPY.get(type(rec))
                if copy is not None:
                    copy(copier, rec)
            if not copier.started:
                copier.w.start()
            copier.w.finish()
        os.replace(tmp, dst)
    finally:
        tmp.unlink(missing_ok=True)
    return RecoverResult(dst, report, copier.messages, len(copier.channels))
