"""A file or FIFO read as a live input (`edged replay` reads logs through the log
reader `logs.NMEA0183` instead).

A regular file ends (the link reports `finished`); a FIFO or character device that
reaches end of stream is reopened like any other link whose peer went away. Reads run
in a worker thread so that a FIFO without a writer cannot block the event loop.
"""

from __future__ import annotations

import asyncio
import os
import stat
from typing import Any, BinaryIO

from .base import Transport


class FileTransport(Transport):
    def __init__(self, path: str) -> None:
        self.path = path
        self._f: BinaryIO | None = None
        self._regular = False

    @classmethod
    def from_config(cls, config: Any) -> "FileTransport":
        return cls(config.path)

    async def open(self) -> None:
        self._f = await asyncio.to_thread(open, self.path, "rb", 0)
        self._regular = stat.S_ISREG(os.fstat(self._f.fileno()).st_mode)

    async def read(self) -> bytes:
        assert self._f is not None, "read before open"
        return await asyncio.to_thread(self._f.read, 65536)

    async def close(self) -> None:
        f, self._f = self._f, None
        if f is not None:
            f.close()

    @property
    def finite(self) -> bool:
        return self._regular

    def describe(self) -> str:
        return f"file {self.path}"
