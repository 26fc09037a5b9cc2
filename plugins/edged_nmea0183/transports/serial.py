"""Serial port (RS-422/RS-232 adapter) through pyserial-asyncio-fast.

pyserial's `Serial.open()` ends with a flush of the input buffer (`tcflush(TCIFLUSH)`
on POSIX): the sentences the device sent while the port was closed (an adapter that
came back, the 2.5 s of a reopen) would be thrown away. The port is opened with a
`Serial` whose open keeps them; pyserial URLs (`socket://`, `rfc2217://`) go through
`serial_for_url` as before.
"""

from __future__ import annotations

import asyncio
from typing import Any

import serial
import serial_asyncio_fast

from .base import StreamTransport


class KeepInputSerial(serial.Serial):  # type: ignore[misc,valid-type]
    """`serial.Serial` whose `open()` does not discard what is already received.

    `reset_input_buffer()` called by its user still flushes: only the flush inside
    `open()` is skipped (POSIX's `_reset_input_buffer`; on Windows `open()` calls
    `reset_input_buffer()` itself and is covered the same way).
    """

    _opening = False

    def open(self) -> None:
        self._opening = True
        try:
            super().open()
        finally:
            self._opening = False

    def _reset_input_buffer(self) -> None:
        if not self._opening:
            super()._reset_input_buffer()

    def reset_input_buffer(self) -> None:
        if not self._opening:
            super().reset_input_buffer()


def open_keeping_input(device: str, baudrate: int) -> serial.Serial:
    """Open `device` at `baudrate` without flushing its input (blocking: a thread's job)."""
    port = KeepInputSerial()
    port.port = device
    port.baudrate = baudrate
    port.open()
    return port


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
        if "://" in self.device:
            self._reader, self._writer = await serial_asyncio_fast.open_serial_connection(
                url=self.device, baudrate=self.baudrate
            )
            return
        loop = asyncio.get_running_loop()
        port = await asyncio.to_thread(open_keeping_input, self.device, self.baudrate)
        reader = asyncio.StreamReader(loop=loop)
        protocol = asyncio.StreamReaderProtocol(reader, loop=loop)
        try:
            transport, _ = await serial_asyncio_fast.connection_for_serial(loop, lambda: protocol, port)
        except BaseException:
            port.close()
            raise
        self._reader = reader
        self._writer = asyncio.StreamWriter(transport, protocol, reader, loop)

    def describe(self) -> str:
        return f"serial {self.device} @ {self.baudrate} Bd"
