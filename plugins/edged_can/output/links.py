"""Where the NMEA 2000 output's messages go: a CAN bus, a YDWG gateway, an Actisense.

Each link is kept open by `edged.link.Link` (reopened with backoff, its state in
`info["link"]`), and `send(frame)` never blocks and never raises: what cannot go is
counted (`unsent.link_down` while the link is down, `dropped.slow_link` when a
gateway does not take the bytes as fast as they come, `errors.send`).

- `CanLink`: python-can (SocketCAN on board, `virtual` in tests). Frames of other
  devices are handed to `on_frame` (the address claim and requests need them). A
  fast-packet PGN is cut into frames here, with a sequence counter per PGN.
- `YdwgLink`: a Yacht Devices YDWG-02/YDEN-02 in RAW mode, a TCP client. A frame is
  written as the gateway takes it for transmission, the RAW line without time and
  direction: `19F50323 00 F4 01 FF FF FF FF FF\\r\\n`. The gateway sends on the bus with
  its own address (it is the device that claimed one); the address in our lines is
  the configured one. What the gateway sends us (the bus's traffic) is read and
  dropped.
- `ActisenseLink`: an Actisense NGT-1 (BST over its USB serial port, or a TCP relay
  of it): whole messages as BST 94 "N2K message to send" (framed by the `nmea2000`
  package's NGT-1 codec; the gateway cuts fast-packets itself). No start-up
  conversation: that turns on the gateway's reception, which an output does not
  need (and the codec holds every message back until the gateway answers it). The
  gateway, too, sends with its own address. Its transmit PGN list must let our PGNs
  through (it is set with Actisense's own tools).
"""

from __future__ import annotations

import asyncio
from typing import Any, Awaitable, Callable

from edged.bytesinks import write_bounded
from edged.health import ComponentHealth
from edged.link import Link, LinkLost, stop_task

from . import wire
from .config import Nmea2000OutputConfig
from .wire import Frame

__all__ = ["N2kLink", "CanLink", "YdwgLink", "ActisenseLink", "make_link"]

#: Seconds without a frame after which a bus session would end: never for an output
#: (it may be alone on the bus; its own frames are not heard back).
_NO_WATCHDOG = 365 * 86400.0
OnFrame = Callable[[int, int, int, bytes], None]  # pgn, src, dst, data


class N2kLink:
    """A link messages are sent on: opened in the background, reopened when it breaks."""

    def __init__(self, config: Nmea2000OutputConfig, health: ComponentHealth, sleep: Any = asyncio.sleep) -> None:
        self.config = config
        self.health = health
        self.link: Link[Any] = Link(health, config.backoff(), where=config.where(), info_key="link", sleep=sleep)
        self._task: asyncio.Task[None] | None = None
        self._seq: dict[int, int] = {}
        #: Frames of other devices (only a bus gives them).
        self.on_frame: OnFrame | None = None
        #: Set while the link is up, and `down` once it went down (the output and the
        #: tests wait for them).
        self.connected = asyncio.Event()
        self.down = asyncio.Event()

    async def open(self) -> None:
        if self._task is None:
            self._task = asyncio.get_running_loop().create_task(self._keep(), name=f"n2k {self.link.where}")

    async def _keep(self) -> None:
        raise NotImplementedError

    async def close(self) -> None:
        task, self._task = self._task, None
        await stop_task(task)
        self.connected.clear()

    def send(self, frame: Frame) -> bool:
        """Send one whole message now; False (counted) when it cannot go."""
        raise NotImplementedError

    def can_frames(self, frame: Frame) -> list[tuple[int, bytes]]:
        """(identifier, data) of each CAN frame of a message; fast-packets cut up."""
        ident = wire.identifier(frame)
        if len(frame.payload) <= 8 and not wire.is_fast(frame.pgn):
            return [(ident, frame.payload)]
        seq = self._seq.get(frame.pgn, 0)
        self._seq[frame.pgn] = (seq + 1) & 7
        return [(ident, f) for f in wire.fragment(seq, frame.payload)]

    async def _session(self, up: Callable[[], Awaitable[None]]) -> None:
        self.down.clear()
        self.connected.set()
        try:
            await up()
        finally:
            self.connected.clear()
            self.down.set()


class CanLink(N2kLink):
    """A python-can bus (see the module's docstring)."""

    def __init__(self, config: Nmea2000OutputConfig, health: ComponentHealth, open_bus: Callable[..., Any] | None = None,
                 sleep: Any = asyncio.sleep) -> None:
        super().__init__(config, health, sleep)
        import can

        self._can = can
        self.link.open_errors = (can.CanError, OSError, ValueError, NotImplementedError)
        self.link.link_errors = ()
        self.open_bus = open_bus or can.Bus
        self._bus: Any = None

    async def _keep(self) -> None:
        from ..bus import pump

        cfg = self.config

        async def opener() -> Any:
            return self.open_bus(interface=cfg.interface, channel=cfg.channel, bitrate=cfg.bitrate)

        async def session(bus: Any) -> None:
            self._bus = bus
            try:
                await self._session(lambda: pump(bus, self._received, self.health, _NO_WATCHDOG))
            finally:
                self._bus = None

        async def shutdown(bus: Any) -> None:
            bus.shutdown()

        await self.link.run(opener, session, shutdown)

    def _received(self, msg: Any) -> None:
        if not msg.is_extended_id or self.on_frame is None:
            return
        ident = msg.arbitration_id
        pf, ps = (ident >> 16) & 0xFF, (ident >> 8) & 0xFF
        pgn = ((ident >> 8) & 0x3FF00) if pf < 240 else ((ident >> 8) & 0x3FFFF)
        self.on_frame(pgn, ident & 0xFF, ps if pf < 240 else 255, bytes(msg.data))

    def send(self, frame: Frame) -> bool:
        bus = self._bus
        if bus is None:
            self.health.count("unsent.link_down")
            return False
        Message = self._can.Message
        try:
            for ident, data in self.can_frames(frame):
                bus.send(Message(arbitration_id=ident, is_extended_id=True, data=data), timeout=0.0)
        except (self._can.CanError, OSError, ValueError) as exc:
            self.health.count("errors.send")
            self.health.error(f"{self.link.where}: send: {exc}")
            return False
        return True


class _StreamLink(N2kLink):
    """A gateway over a byte stream (TCP or serial): bytes written, what comes read."""

    def __init__(self, config: Nmea2000OutputConfig, health: ComponentHealth, sleep: Any = asyncio.sleep) -> None:
        super().__init__(config, health, sleep)
        self._writer: asyncio.StreamWriter | None = None

    async def _connect(self) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        cfg = self.config
        if cfg.device:
            from edged.serialport import open_serial

            return await open_serial(cfg.device, cfg.baudrate)
        return await asyncio.open_connection(cfg.host, cfg.gateway_port())

    async def _keep(self) -> None:
        async def session(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter]) -> None:
            reader, writer = conn
            self._writer = writer
            try:
                async def read() -> None:  # the bus's traffic the gateway sends: dropped
                    while await reader.read(65536):
                        self.link.stable()
                    raise LinkLost("closed by the gateway")

                await self._session(read)
            finally:
                self._writer = None

        async def close(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter]) -> None:
            conn[1].close()

        await self.link.run(self._connect, session, close)

    def _bytes(self, frame: Frame) -> bytes:
        raise NotImplementedError

    def send(self, frame: Frame) -> bool:
        w = self._writer
        if w is None or w.transport.is_closing():
            self.health.count("unsent.link_down")
            return False
        try:
            data = self._bytes(frame)
        except wire.EncodeError as exc:
            self.health.count("errors.send")
            self.health.error(f"{self.link.where}: PGN {frame.pgn}: {exc}")
            return False
        return write_bounded(w, data, self.config.link_buffer, self.health, self.link.where, "dropped.slow_link")


class YdwgLink(_StreamLink):
    """YDWG-02 RAW over TCP (see the module's docstring)."""

    def _bytes(self, frame: Frame) -> bytes:
        return b"".join(
            f"{ident:08X}{''.join(f' {b:02X}' for b in data)}\r\n".encode("ascii")
            for ident, data in self.can_frames(frame))


class ActisenseLink(_StreamLink):
    """Actisense NGT-1 BST (see the module's docstring)."""

    def __init__(self, config: Nmea2000OutputConfig, health: ComponentHealth, sleep: Any = asyncio.sleep) -> None:
        super().__init__(config, health, sleep)
        self._codec = wire.ngt1()

    def _bytes(self, frame: Frame) -> bytes:
        return self._codec.send(frame.pgn, frame.payload, frame.src, frame.dst, frame.prio)


def make_link(config: Nmea2000OutputConfig, health: ComponentHealth) -> N2kLink:
    """The link of the configured transport."""
    if config.transport == "can":
        return CanLink(config, health)
    if config.transport == "ydwg":
        return YdwgLink(config, health)
    return ActisenseLink(config, health)
