"""Serial port (RS-422/RS-232 adapter): the core's `edged.serialport`, opened without
flushing what the adapter already received, pyserial URLs accepted."""

from __future__ import annotations

from typing import Any

from edged.serialport import open_serial

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
        self._reader, self._writer = await open_serial(self.device, self.baudrate)

    def describe(self) -> str:
        return f"serial {self.device} @ {self.baudrate} Bd"
