"""Serial port (RS-422/RS-232 adapter) through pyserial-asyncio-fast."""

from __future__ import annotations

from typing import Any

import serial_asyncio_fast

from .base import StreamTransport


class SerialTransport(StreamTransport):
    read_size = 4096  # at 38400 Bd a read of 4 KiB is a second of data
    def __init__(self, device: str, baudrate: int = 4800) -> None:
        self.device = device
        self.baudrate = baudrate
        super().__init__()

    @classmethod
    def from_config(cls, config: Any) -> "SerialTransport":
        return cls(config.device, config.baudrate)

    async def open(self) -> None:
        # pyserial's SerialException is an OSError: a missing device is a failed connect.
        self._reader, self._writer = await serial_asyncio_fast.open_serial_connection(
            url=self.device, baudrate=self.baudrate
        )

    def describe(self) -> str:
        return f"serial {self.device} @ {self.baudrate} Bd"
