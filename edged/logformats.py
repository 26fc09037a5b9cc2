"""Which installed log reader reads a file (`edged replay`, DESIGN §8), and a file
wrapper that counts the bytes read for the progress bar."""

from __future__ import annotations

import io
import logging
from pathlib import Path
from typing import Any, BinaryIO

from .plugin import LogReader
from .registry import Registry

log = logging.getLogger("edged.replay")

#: What `detect` gives the readers' `sniff`: enough for a few hundred lines, so that
#: a noisy start (line noise before a serial logger synchronised) does not hide the
#: format of the rest.
HEAD_BYTES = 32768
class UnknownFormat(ValueError):
    """A file no installed log reader can read (names the file)."""


class CountingReader(io.RawIOBase):
    """Wraps a binary file to count the bytes read, for the progress bar."""

    def __init__(self, f: BinaryIO, source: str = "") -> None:
        self._f = f
        self.count = 0
        #: The source the file's records are of (its name without the suffix).
        self.source = source

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return self._f.seekable()

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        return self._f.seek(offset, whence)

    def tell(self) -> int:
        return self._f.tell()

    def readinto(self, b: Any) -> int:
        n = self._f.readinto(b)  # type: ignore[attr-defined]
        if n:
            self.count += n
        return n or 0

    def close(self) -> None:
        self._f.close()
        super().close()


#: The priority of a reader whose `priority` is not an integer: after every other.
LAST = 1 << 30


def log_readers(registry: Registry) -> list[tuple[str, LogReader]]:
    """Every installed log reader, in sniff order: `priority` (lower first), then name.

    Each is loaded to learn its priority: a reader's module is light (DESIGN §1), the
    decoding stacks are imported by `open` and by the decoders, for its files only."""
    readers = []
    for name, reader in registry.iter("logs"):
        prio = getattr(reader, "priority", None)
        if not isinstance(prio, int) or isinstance(prio, bool):
            log.warning("log reader %s: priority %r is not an integer: sniffed last", name, prio)
            prio = LAST
        readers.append((prio, name, reader))
    readers.sort(key=lambda r: (r[0], r[1]))
    return [(name, reader) for _, name, reader in readers]


def detect(path: Path, registry: Registry) -> tuple[str, LogReader]:
    """The log reader of `path`, recognised by its first `HEAD_BYTES`: the first
    reader, in priority order, whose `sniff` says yes."""
    try:
        with open(path, "rb") as f:
            head = f.read(HEAD_BYTES)
    except OSError as exc:
        raise UnknownFormat(f"{path}: cannot read: {exc.strerror or exc}") from None
    readers = log_readers(registry)
    for name, reader in readers:
        try:
            if reader.sniff(head):
                return name, reader
        except Exception as exc:  # a reader's sniff must not decide for the others
            log.warning("log reader %s: sniff failed on %s: %s", name, path, exc)
    kinds = ", ".join(n for n, _ in readers) or "none installed"
    raise UnknownFormat(f"{path}: format not recognised (readers: {kinds})")


def file_size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0
