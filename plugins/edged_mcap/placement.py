"""Where the recorder's next file goes, and whether the disk has room for it.

A disk without room leaves no file behind: the free space is checked before a file is
created (at least the configured floor, `min_free_gib`, and room for a chunk and the
file's own records, `FILE_HEADROOM`), and measured again at every flush. With an exact
`path` (`edged replay --record OUT.mcap`) the first file keeps the exact name and the
next ones are numbered beside it (`numbered`); in directory mode each file is named by
its start time (`files.new_file`) and the oldest beyond the retention limits are
deleted once a new one has begun.
"""

from __future__ import annotations

from pathlib import Path

import edged
from edged.plugin import PluginContext

from . import files
from .config import GIB, McapConfig

__all__ = ["FILE_HEADROOM", "Placement", "numbered"]

#: Room a new file needs beyond one chunk (header, metadata, indexes, summary).
FILE_HEADROOM = 256 * 1024


def numbered(path: Path, n: int) -> Path:
    """The n-th file of an exact recording: `OUT.mcap`, then `OUT.001.mcap`, ..."""
    if n == 0:
        return path
    return path.with_name(f"{path.stem}.{n:03d}{path.suffix}")


class Placement:
    """The recorder's folder: the next file's path and metadata, free space, retention.
    What it finds goes to the recorder's health (`info.disk_free_bytes`, errors,
    `files_deleted`)."""

    def __init__(self, config: McapConfig, ctx: PluginContext, free_bytes: files.FreeBytes) -> None:
        self.config = config
        self.ctx = ctx
        self._free_bytes = free_bytes

    @property
    def folder(self) -> Path:
        cfg = self.config
        return cfg.directory if cfg.directory is not None else cfg.path.parent  # type: ignore[union-attr]

    def target(self, made: int) -> Path:
        """The path of the next file, after `made` files of this recording."""
        cfg = self.config
        if cfg.path is not None:
            return numbered(cfg.path, made)
        assert cfg.directory is not None
        return files.new_file(cfg.directory, self.ctx.clock.now())

    def measure_free(self, folder: Path) -> int | None:
        """Free bytes of `folder`, published in health; None when unknown."""
        try:
            free = int(self._free_bytes(folder))
        except (OSError, TypeError, ValueError) as exc:
            self.ctx.health.error(f"free space of {folder}: {getattr(exc, 'strerror', None) or exc}")
            return None
        self.ctx.health.info["disk_free_bytes"] = free
        return free

    def enough_space(self, folder: Path, free: int | None = None) -> bool:
        """False (and said in health) when the free space is below the floor;
        measured unless `free` is given. Unknown is not low."""
        floor = int(self.config.min_free_gib * GIB)
        if free is None:
            free = self.measure_free(folder)
        if free is None:
            return True  # unknown is not low: keep recording, the write itself will tell
        if free < floor:
            self.ctx.health.error(
                f"free disk {free / GIB:.2f} GiB below the floor {self.config.min_free_gib} GiB: recording stopped"
            )
            return False
        return True

    def room_needed(self) -> int:
        """Bytes a new file needs at least: a chunk and the file's own records."""
        return self.config.chunk_kib * 1024 + FILE_HEADROOM

    def metadata(self) -> dict[str, str]:
        """The `edged` metadata record of a new file."""
        return {
            "vessel_id": self.ctx.vessel_id,
            "edged_version": edged.__version__,
            "config": str(self.ctx.options.get("config_text") or ""),
            "started": files.stamp(self.ctx.clock.now()),
        }

    def prune(self, current: Path) -> None:
        """Delete the oldest files beyond the retention limits (directory mode), never
        `current`."""
        cfg = self.config
        if cfg.directory is None or (cfg.keep_files is None and cfg.keep_gib is None):
            return
        keep_bytes = int(cfg.keep_gib * GIB) if cfg.keep_gib is not None else None
        try:
            deleted = files.prune(cfg.directory, cfg.keep_files, keep_bytes, current)
        except OSError as exc:
            self.ctx.health.error(f"retention: {exc.strerror or exc}")
            return
        if deleted:
            self.ctx.health.count("files_deleted", len(deleted))
            self.ctx.log.info("event=retention deleted=%s", ",".join(p.name for p in deleted))
