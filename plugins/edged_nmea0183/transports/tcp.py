"""TCP client, e.g. to an NMEA multiplexer (port 10110 by convention)."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

from .base import Transport


class TcpTransport(Transport):
    def __init__(self, host: str, port: int) -> None:
        self.host = host
        self.port = port
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None

    @classmethod
    def from_config(cls, config: Any) -> "TcpTransport":
        return cls(config.host, config.port)

    async def open(self) -> None:
        self._reader, self._writer = await asyncio.open_connection(self.host, self.port)

    async def read(self) -> bytes:
        assert self._reader is not None, "read before open"
        return await self._reader.read(65536)

    async def close(self) -> None:
        w, self._writer, self._reader = self._writer, None, None
        if w is not None:
            w.close()
            with contextlib.suppress(OSError):
                await w.wait_closed()

    def describe(self) -> str:
        return f"tcp {self.host}:{self.port}"
