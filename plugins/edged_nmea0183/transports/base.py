"""The interface every transport implements (in the spirit of python-can's BusABC).

A transport only moves bytes: `open`, `read` (some bytes; b"" at end of stream),
`close`. Staying open, the watchdog, reconnecting and backoff are the link's job
(`edged_nmea0183.link`), so each transport stays a few lines of asyncio.
"""

from __future__ import annotations

import asyncio
import contextlib
from abc import ABC, abstractmethod
from typing import Any, ClassVar


class Transport(ABC):
    #: True when each `read` returns whole datagrams: a line ends with its datagram.
    message_oriented: ClassVar[bool] = False

    @classmethod
    @abstractmethod
    def from_config(cls, config: Any) -> "Transport": ...

    @abstractmethod
    async def open(self) -> None:
        """Connect; raise OSError when the peer or device is not there."""

    @abstractmethod
    async def read(self) -> bytes:
        """The next bytes received; b"" when the peer closed the stream.

        Raises OSError when the link breaks (a serial adapter unplugged).
        """

    @abstractmethod
    async def close(self) -> None:
        """Release the link; safe to call when not open."""

    def counters(self) -> dict[str, int]:
        """What this transport lost before the framer saw it, as running totals since
        it was made, across reopens (`dropped.kernel`, `dropped.queue`); the input
        copies them into its health counters at every health snapshot."""
        return {}

    def info(self) -> dict[str, Any]:
        """Settings as they took effect (`rcvbuf`), for health `info`."""
        return {}

    @property
    def finite(self) -> bool:
        """True when end of stream means "done" (a regular file), not "reconnect"."""
        return False

    @abstractmethod
    def describe(self) -> str:
        """Where it reads from, for logs and health (`tcp 10.0.0.5:10110`)."""


class StreamTransport(Transport):
    """A transport asyncio gives as a reader/writer pair (TCP, serial): `open` sets them."""

    #: Bytes asked of the stream per read.
    read_size: ClassVar[int] = 65536

    def __init__(self) -> None:
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None

    async def read(self) -> bytes:
        assert self._reader is not None, "read before open"
        return await self._reader.read(self.read_size)

    async def close(self) -> None:
        w, self._writer, self._reader = self._writer, None, None
        if w is not None:
            w.close()
            with contextlib.suppress(OSError):
                await w.wait_closed()
