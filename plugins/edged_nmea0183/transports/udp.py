"""UDP listener, unicast or broadcast (instruments and multiplexers that send to 10110).

Datagrams are queued by the protocol callback and handed out by `read`; the queue is
bounded so that a stalled consumer cannot grow memory: overflow drops the datagram and
counts it (`dropped`).
"""

from __future__ import annotations

import asyncio
from typing import Any

from .base import Transport

QUEUE_SIZE = 10_000


class _Receiver(asyncio.DatagramProtocol):
    def __init__(self, queue: "asyncio.Queue[bytes | BaseException]", owner: "UdpTransport") -> None:
        self._queue = queue
        self._owner = owner

    def datagram_received(self, data: bytes, addr: Any) -> None:
        try:
            self._queue.put_nowait(data)
        except asyncio.QueueFull:
            self._owner.dropped += 1

    def error_received(self, exc: Exception) -> None:  # e.g. ICMP errors; not fatal
        pass

    def connection_lost(self, exc: Exception | None) -> None:
        if exc is not None:
            self._queue.put_nowait(exc)


class UdpTransport(Transport):
    message_oriented = True

    def __init__(self, bind: str, port: int, broadcast: bool = False) -> None:
        self.bind = bind
        self.port = port
        self.broadcast = broadcast
        self.dropped = 0
        self._transport: asyncio.DatagramTransport | None = None
        self._queue: asyncio.Queue[bytes | BaseException] | None = None

    @classmethod
    def from_config(cls, config: Any) -> "UdpTransport":
        return cls(config.bind, config.port, config.broadcast)

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[bytes | BaseException] = asyncio.Queue(QUEUE_SIZE)
        # Broadcast: other listeners on the gateway (a chart plotter) share the port.
        self._transport, _ = await loop.create_datagram_endpoint(
            lambda: _Receiver(queue, self),
            local_addr=(self.bind, self.port),
            allow_broadcast=self.broadcast,
            reuse_port=self.broadcast or None,
        )
        self._queue = queue

    @property
    def local_port(self) -> int | None:
        """The port actually bound (differs from `port` when 0 was asked, in tests)."""
        if self._transport is None:
            return None
        return self._transport.get_extra_info("sockname")[1]

    async def read(self) -> bytes:
        assert self._queue is not None, "read before open"
        item = await self._queue.get()
        if isinstance(item, BaseException):
            raise OSError(f"udp socket failed: {item}") from item
        return item

    async def close(self) -> None:
        t, self._transport, self._queue = self._transport, None, None
        if t is not None:
            t.close()

    def describe(self) -> str:
        return f"udp {self.bind}:{self.port}" + (" (broadcast)" if self.broadcast else "")
