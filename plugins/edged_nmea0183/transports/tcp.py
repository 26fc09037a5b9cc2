"""TCP client, e.g. to an NMEA multiplexer (port 10110 by convention)."""

from __future__ import annotations

import asyncio
from typing import Any

from .base import StreamTransport


class TcpTransport(StreamTransport):
    def __init__(self, host: str, port: int) -> None:
        self.host = host
        self.port = port
        super().__init__()

    @classmethod
    def from_config(cls, config: Any) -> "TcpTransport":
        return cls(config.host, config.port)

    async def open(self) -> None:
        self._reader, self._writer = await asyncio.open_connection(self.host, self.port)

    def describe(self) -> str:
        return f"tcp {self.host}:{self.port}"
