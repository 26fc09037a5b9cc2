"""A serial port (an RS-422/RS-232 or USB adapter) as an asyncio reader/writer pair.

Here, in the core, because it moves bytes and knows no sensor: the NMEA 0183 input
reads sentences through it and the NMEA 2000 gateway input (`n2k_gateway`) an NGT-1's
or an iKonvert's stream, and neither plugin may import the other (issue 33).

pyserial's `Serial.open()` ends with a flush of the input buffer (`tcflush(TCIFLUSH)`
on POSIX): what the device sent while the port was closed (an adapter that came back,
the 2.5 s of a reopen) would be thrown away. The port is opened with a `Serial` whose
open keeps it; pyserial URLs (`socket://`, `rfc2217://`) go through `serial_for_url`.
"""

from __future__ import annotations

import asyncio

import serial
import serial_asyncio_fast

__all__ = ["KeepInputSerial", "open_keeping_input", "open_serial"]

Streams = tuple[asyncio.StreamReader, asyncio.StreamWriter]


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


async def open_serial(device: str, baudrate: int) -> Streams:
    """The reader/writer pair of `device` (a path, or a pyserial URL with `://`).

    Raises OSError when the device is not there (pyserial's SerialException is one):
    to a link, a failed connect."""
    if "://" in device:
        return await serial_asyncio_fast.open_serial_connection(url=device, baudrate=baudrate)
    loop = asyncio.get_running_loop()
    port = await asyncio.to_thread(open_keeping_input, device, baudrate)
    reader = asyncio.StreamReader(loop=loop)
    protocol = asyncio.StreamReaderProtocol(reader, loop=loop)
    try:
        transport, _ = await serial_asyncio_fast.connection_for_serial(loop, lambda: protocol, port)
    except BaseException:
        port.close()
        raise
    return reader, asyncio.StreamWriter(transport, protocol, reader, loop)
