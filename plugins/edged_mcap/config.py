"""Configuration of the MCAP recorder output (`[outputs.<name>] type = "mcap"`)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from edged.plugin import OutputConfig

__all__ = ["McapConfig", "GIB"]

GIB = 1 << 30
#: Bounds of the sizes (numbers are finite and bounded, as in every configuration).
MAX_BYTES = 1 << 50  # 1 PiB
MAX_GIB = float(1 << 20)  # 1 PiB


class McapConfig(OutputConfig):
    """Where and how to record.

    `path` records exactly one file (what `edged replay --record OUT.mcap` asks for);
    `directory` records rotated files `edged-<UTC start>.mcap` (the daemon). Rotation,
    retention and the retry after a stop apply to `directory` only: an exact file is
    never reopened once it holds data (reopening would truncate it), and split only at
    the chunk-index bound, into numbered files `OUT.001.mcap`, ... (flat memory).
    """

    type: str = "mcap"
    #: A recorder runs in a process of its own by default: encoding, chunking,
    #: compressing and fsyncing every record is as much work as decoding it, and a
    #: disk that stalls must not hold the daemon's loop.
    worker: Literal["loop", "process"] = "process"
    path: Path | None = None
    directory: Path | None = None
    #: Start a new file when the current one reaches this size (bytes).
    rotate_bytes: int | None = Field(256 * 1024 * 1024, gt=0, le=MAX_BYTES)
    #: Start a new file after this many seconds (at most 31 days).
    rotate_seconds: float | None = Field(3600.0, gt=0, le=31 * 86_400.0)
    #: Retention: keep at most this many files (the newest) ...
    keep_files: int | None = Field(None, ge=1, le=10_000_000)
    #: ... and at most this many GiB of files (the newest; the current one always stays).
    keep_gib: float | None = Field(None, gt=0, le=MAX_GIB)
    #: Stop recording (never the daemon) while the disk has less free space than this.
    min_free_gib: float = Field(1.0, ge=0, le=MAX_GIB)
    #: Seconds between checks of free space and, once stopped, attempts to resume.
    retry_seconds: float = Field(10.0, gt=0, le=3600.0)
    compression: Literal["zstd", "lz4", "none"] = "zstd"
    #: Chunk size bound: a power loss costs at most one chunk not yet written.
    chunk_kib: int = Field(64, ge=1, le=1024)
    #: fsync at every flush (about once a second): data survives a power loss, not
    #: only a crash of the process.
    fsync: bool = True

    @field_validator("path", "directory")
    @classmethod
    def _relative_to_config(cls, v: Path | None, info: ValidationInfo) -> Path | None:
        base = (info.context or {}).get("config_dir")
        if v is not None and base is not None and not v.is_absolute():
            return Path(base) / v
        return v

    @model_validator(mode="after")
    def _one_target(self) -> "McapConfig":
        if (self.path is None) == (self.directory is None):
            raise ValueError("set exactly one of 'path' (one exact file) or 'directory' (rotated files)")
        return self
