"""UDP listener, unicast or broadcast (instruments and multiplexers that send to 10110).

Datagrams are queued by the protocol callback and handed out by `read`; the queue is
bounded so that a stalled consumer cannot grow memory: overflow drops the datagram and
counts it (`dropped`, in health `dropped.queue`).

The kernel drops datagrams too, before edged sees them, when the socket's receive
buffer is full (a flood, or a loop busy elsewhere). Those are read from the socket's
own drop counter (Linux: `SO_MEMINFO`, else the `drops` column of `/proc/net/udp`
matched by the socket's inode) and reported as `dropped.kernel`; `rcvbuf` (bytes,
`SO_RCVBUF`) gives the socket a larger buffer than the system default.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
import struct
import sys
from typing import Any

from .base import Transport

QUEUE_SIZE = 10_000

log = logging.getLogger("edged.nmea0183.udp")

#: Linux `SO_MEMINFO` (include/uapi/asm-generic/socket.h) and the index of
#: `SK_MEMINFO_DROPS` in the array of u32 it returns (Linux >= 4.12).
SO_MEMINFO = getattr(socket, "SO_MEMINFO", 55)
_SK_MEMINFO_DROPS = 8
_MEMINFO_LEN = 4 * (_SK_MEMINFO_DROPS + 1)
_U32 = 0xFFFF_FFFF
_PROC_NET = "/proc/net"


def _meminfo_drops(sock: Any) -> int | None:
    try:
        raw = sock.getsockopt(socket.SOL_SOCKET, SO_MEMINFO, _MEMINFO_LEN)
    except (OSError, TypeError):
        return None
    if not isinstance(raw, bytes) or len(raw) < _MEMINFO_LEN:
        return None
    return struct.unpack_from("=I", raw, 4 * _SK_MEMINFO_DROPS)[0]


def proc_drops(sock: Any, proc_net: str = _PROC_NET) -> int | None:
    """The `drops` column of the socket's line in /proc/net/udp{,6}, by inode; None
    when there is no such file or line."""
    try:
        inode = str(os.fstat(sock.fileno()).st_ino)
    except (OSError, ValueError):
        return None
    for name in ("udp", "udp6"):
        try:
            with open(os.path.join(proc_net, name), encoding="ascii", errors="replace") as f:
                next(f, None)  # header
                for line in f:
                    fields = line.split()
                    # sl local rem st tx:rx tr:when retrnsmt uid timeout inode ref pointer drops
                    if len(fields) >= 13 and fields[9] == inode:
                        try:
                            return int(fields[12])
                        except ValueError:
                            return None
        except OSError:
            continue
    return None


def kernel_drops(sock: Any) -> int | None:
    """Datagrams the kernel dropped on this socket since it was made (a u32 that
    wraps), or None when the platform does not say."""
    if not sys.platform.startswith("linux"):
        return None
    n = _meminfo_drops(sock)
    return n if n is not None else proc_drops(sock)


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
            try:
                self._queue.put_nowait(exc)
            except asyncio.QueueFull:  # a flood filled the queue: read() raises it next
                self._owner.failure = exc


class UdpTransport(Transport):
    message_oriented = True

    def __init__(self, bind: str, port: int, broadcast: bool = False, rcvbuf: int | None = None) -> None:
        self.bind = bind
        self.port = port
        self.broadcast = broadcast
        #: SO_RCVBUF asked for (bytes); None keeps the system default.
        self.rcvbuf = rcvbuf
        #: Datagrams dropped because the queue to the framer was full.
        self.dropped = 0
        #: A socket failure that found the queue full (a flood): read() raises it.
        self.failure: BaseException | None = None
        #: Datagrams the kernel dropped, summed over every socket this transport opened.
        self.kernel_dropped = 0
        #: False when the platform cannot tell kernel drops (then not reported).
        self.kernel_drops_known = False
        self._kernel_seen = 0  # the open socket's counter at the last look
        self._rcvbuf_actual: int | None = None
        self._transport: asyncio.DatagramTransport | None = None
        self._queue: asyncio.Queue[bytes | BaseException] | None = None

    @classmethod
    def from_config(cls, config: Any) -> "UdpTransport":
        return cls(config.bind, config.port, config.broadcast, getattr(config, "rcvbuf", None))

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
        sock = self._transport.get_extra_info("socket")
        if self.rcvbuf is not None:
            self._set_rcvbuf(sock, self.rcvbuf)
        try:
            self._rcvbuf_actual = sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        except OSError:
            self._rcvbuf_actual = None
        first = kernel_drops(sock)
        self.kernel_drops_known = first is not None
        self._kernel_seen = first or 0

    def _set_rcvbuf(self, sock: Any, size: int) -> None:
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size)
        except OSError as exc:
            log.warning("%s: cannot set rcvbuf %d: %s", self.describe(), size, exc)
            return
        try:
            got = sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        except OSError:
            return
        # Linux doubles what it is given (bookkeeping) and caps it at net.core.rmem_max.
        if got < size:
            log.warning(
                "%s: rcvbuf %d asked, the system gives %d (raise net.core.rmem_max)", self.describe(), size, got
            )

    def poll_kernel_drops(self) -> int:
        """Add the drops of the open socket since the last look; the running total."""
        t = self._transport
        if t is not None and self.kernel_drops_known:
            n = kernel_drops(t.get_extra_info("socket"))
            if n is not None:
                self.kernel_dropped += (n - self._kernel_seen) & _U32
                self._kernel_seen = n
        return self.kernel_dropped

    def counters(self) -> dict[str, int]:
        out = {"dropped.queue": self.dropped}
        self.poll_kernel_drops()
        if self.kernel_drops_known:
            out["dropped.kernel"] = self.kernel_dropped
        return out

    def info(self) -> dict[str, Any]:
        return {"rcvbuf": self._rcvbuf_actual} if self._rcvbuf_actual is not None else {}

    @property
    def local_port(self) -> int | None:
        """The port actually bound (differs from `port` when 0 was asked, in tests)."""
        if self._transport is None:
            return None
        return self._transport.get_extra_info("sockname")[1]

    async def read(self) -> bytes:
        assert self._queue is not None, "read before open"
        failure, self.failure = self.failure, None
        if failure is not None and self._queue.empty():
            raise OSError(f"udp socket failed: {failure}") from failure
        if failure is not None:
            self.failure = failure  # what was queued before it is read first
        item = await self._queue.get()
        if isinstance(item, BaseException):
            raise OSError(f"udp socket failed: {item}") from item
        return item

    async def close(self) -> None:
        self.poll_kernel_drops()  # the closing socket's last drops are kept
        t, self._transport, self._queue = self._transport, None, None
        self._kernel_seen = 0
        if t is not None:
            t.close()

    def describe(self) -> str:
        return f"udp {self.bind}:{self.port}" + (" (broadcast)" if self.broadcast else "")
