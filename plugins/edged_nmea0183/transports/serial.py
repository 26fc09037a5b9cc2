"""Serial port (RS-422/RS-232 adapter) through pyserial-asyncio-fast."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

import serial_asyncio_fast

from .base import Transport


class SerialTransport(Transport):
    def __init__(self, device: str, baudrate: int = 4800) -> None:
        self.device = device
        self.baudrate = baudrate
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None

    @classmethod
    def from_config(cls, config: Any) -> "SerialTransport":
        return cls(config.device, config.baudrate)

    async def open(self) -> None:
        # pyserial's SerialException is an OSError: a missing device is a failed connect.
        self._reader, self._writer = await serial_asyncio_fast.open_serial_connection(
            url=self.device, baudrate=self.baudrate
        )

    async def read(self) -> bytes:
        assert self._reader is not None, "read before open"
        return await self._reader.read(4096)

    async def close(self) -> None:
        w, self._writer, self._reader = self._writer, None, None
        if w is not None:
            w.close()
            with contextlib.suppress(OSError):
                await w.wait_closed()

    def describe(self) -> str:
        return f"serial {self.device} @ {self.baudrate} Bd"
