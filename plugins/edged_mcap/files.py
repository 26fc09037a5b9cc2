"""The recording folder: file names, retention and free space.

Files are `edged-<UTC start, ISO 8601 basic>.mcap` (DESIGN §4); two files started in
the same second get `-1`, `-2` … so that nothing is ever overwritten. Retention only
ever deletes files matching that pattern (never a `.recovered.mcap` or a user's file).
"""

from __future__ import annotations

import os
import re
import shutil
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, NamedTuple

__all__ = ["FreeBytes", "disk_free", "stamp", "new_file", "recordings", "prune"]

#: How the recorder asks for free space (injectable: tests fake a full disk).
FreeBytes = Callable[[Path], int]

_NAME = re.compile(r"^edged-(\d{8}T\d{6}Z)(?:-(\d+))?\.mcap$")


def disk_free(path: Path) -> int:
    """Bytes available to an unprivileged writer on the file system holding `path`."""
    return shutil.disk_usage(path).free


def stamp(t: float) -> str:
    """UTC seconds as ISO 8601 basic, e.g. `20261123T182100Z`."""
    return datetime.fromtimestamp(t, tz=timezone.utc).strftime("%Y%m%dT%H%M%SZ")


def new_file(directory: Path, t: float) -> Path:
    """A file name for a recording starting at `t` that does not exist yet."""
    base = f"edged-{stamp(t)}"
    p = directory / f"{base}.mcap"
    n = 0
    while p.exists():
        n += 1
        p = directory / f"{base}-{n}.mcap"
    return p


class Recording(NamedTuple):
    path: Path
    size: int


def recordings(directory: Path) -> list[Recording]:
    """edged's recordings in `directory`, oldest first."""
    found: list[tuple[tuple[str, int], Recording]] = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return []
    for e in entries:
        m = _NAME.match(e.name)
        if m is None or not e.is_file():
            continue
        try:
            size = e.stat().st_size
        except OSError:  # deleted meanwhile
            continue
        found.append(((m.group(1), int(m.group(2) or 0)), Recording(Path(e.path), size)))
    found.sort(key=lambda x: x[0])
    return [r for _, r in found]


def prune(directory: Path, keep_files: int | None, keep_bytes: int | None, current: Path | None) -> list[Path]:
    """Delete the oldest recordings beyond the limits; return what was deleted.

    The current file always stays and counts against the limits.
    """
    files = recordings(directory)
    kept_n = 0
    kept_bytes = 0
    full = False
    doomed: list[Path] = []
    for r in reversed(files):  # newest first; once one is beyond a limit, so are all older
        is_current = current is not None and r.path == current
        full = full or not (
            (keep_files is None or kept_n < keep_files)
            and (keep_bytes is None or kept_bytes + r.size <= keep_bytes)
        )
        if full and not is_current:
            doomed.append(r.path)
        else:
            kept_n += 1
            kept_bytes += r.size
    deleted = []
    for p in doomed:
        try:
            p.unlink()
            deleted.append(p)
        except FileNotFoundError:
            pass
    return deleted
