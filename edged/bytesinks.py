"""The byte links a text protocol goes out on: UDP, a TCP server, a serial port.

One configuration (`TransportSettings`) and one interface (`ByteSink`) for every
text output (NMEA 0183 sentences, Signal K deltas), each link kept open by
`edged.link.Link` (reopened with backoff, its state in `info["link"]`), so an
output never stops for a dead peer:

- `udp`: datagrams to `host:port`, one message each; `broadcast = true` for a
  broadcast address (the usual way of NMEA 0183 over Ethernet on a small ship);
- `tcp`: a server on `host:port` for up to `max_clients` clients (a chart plotter, an
  ECDIS, signalk-server's "Signal K over TCP" connection). A client that does not
  read loses messages once `client_buffer` bytes wait for it (counted
  `dropped.slow_client`); it never slows the others or the daemon;
- `serial`: a serial port (an RS-422 line to the instruments) at `baudrate`.

`send` never blocks and never raises: what cannot go is counted (and `send` says
False) (`unsent.link_down`
while the link is being reopened, `dropped.slow_client`, `errors.send`).
Servers bind 127.0.0.1 unless configured: a bridge that serves the ship's LAN says
`host = "0.0.0.0"` (or the LAN's address) on purpose.
"""

from __future__ import annotations

import asyncio
import socket
from typing import Any, Literal

from pydantic import Field, model_validator

from .config import ReconnectSettings
from .health import ComponentHealth
from .link import Link, LinkLost, stop_task
from .plugin import Claim, listen_claim, serial_claim
from .serialport import open_serial

__all__ = ["TransportSettings", "ByteSink", "UdpSink", "TcpServerSink", "SerialSink", "make_sink", "write_bounded"]


def write_bounded(w: asyncio.StreamWriter | None, data: bytes, limit: int, health: ComponentHealth,
                  where: str, dropped: str = "dropped.slow_client") -> bool:
    """Write `data` to a stream without waiting: False, counted, when the stream is
    closed (`unsent.link_down`), when more than `limit` bytes would wait for a peer
    slower than the messages (`dropped`), or when the write fails (`errors.send`)."""
    if w is None or w.transport.is_closing():
        health.count("unsent.link_down")
        return False
    if w.transport.get_write_buffer_size() + len(data) > limit:
        health.count(dropped)
        return False
    try:
        w.write(data)
    except OSError as exc:
        health.count("errors.send")
        health.error(f"{where}: write: {exc}")
        return False
    return True


class TransportSettings(ReconnectSettings):
    """Mixin of a text output's configuration: where its bytes go."""

    #: `udp` (datagrams to host:port), `tcp` (a server for several clients), `serial`.
    transport: Literal["udp", "tcp", "serial"] = "udp"
    #: udp: the destination; tcp: the address the server binds (127.0.0.1: this
    #: computer only; "0.0.0.0" for the ship's LAN).
    host: str = "127.0.0.1"
    #: udp: the destination port; tcp: the port served (0: the kernel chooses, and
    #: health says which in `info["port"]`).
    port: int = Field(10110, ge=0, le=65535)
    #: udp: allow a broadcast destination (e.g. 192.168.1.255).
    broadcast: bool = False
    #: serial: the device (/dev/ttyUSB0).
    device: str | None = None
    #: serial: the line's speed (4800 for NMEA 0183, 38400 for its high-speed variant).
    baudrate: int = Field(4800, ge=300, le=4_000_000)
    #: tcp: clients served at once; more are refused (`rejected.too_many_clients`).
    max_clients: int = Field(8, ge=1, le=256)
    #: tcp: bytes that may wait for one client before its messages are dropped.
    client_buffer: int = Field(65536, ge=1024, le=64 * 1024 * 1024)

    def claims(self) -> list[Claim]:
        """The TCP port it serves (port 0: any free one, no claim) and the serial port
        it writes: one user each, input or output."""
        out: list[Claim] = []
        nxt = getattr(super(), "claims", None)
        if nxt is not None:
            out += nxt()
        if self.transport == "tcp" and self.port:
            out.append(listen_claim("port", "tcp", self.host, self.port))
        elif self.transport == "serial" and self.device:
            out += serial_claim(self.device, text=f"write serial {self.device}")
        return out

    @model_validator(mode="after")
    def _serial_needs_device(self) -> "TransportSettings":
        if self.transport == "serial" and not self.device:
            raise ValueError('transport = "serial" needs a device (e.g. device = "/dev/ttyUSB0")')
        if self.transport == "udp" and self.port == 0:
            raise ValueError("udp needs the port the datagrams go to (port 0 is none)")
        return self


class ByteSink:
    """A link bytes are sent on: opened in the background, reopened when it breaks."""

    def __init__(self, settings: TransportSettings, health: ComponentHealth, where: str) -> None:
        self.settings = settings
        self.health = health
        self.link: Link[Any] = Link(health, settings.backoff(), where=where, info_key="link")
        self._task: asyncio.Task[None] | None = None

    async def open(self) -> None:
        """Start keeping the link open (returns at once; the link comes up behind)."""
        if self._task is None:
            self._task = asyncio.get_running_loop().create_task(self._keep(), name=f"sink {self.link.where}")

    async def _keep(self) -> None:
        raise NotImplementedError

    def send(self, data: bytes) -> bool:
        """Send one message now, or count why it cannot go (False). A TCP server with
        no client has sent it: nobody listening is not a loss."""
        raise NotImplementedError

    @property
    def up(self) -> bool:
        return self.health.info.get("link") == "connected"

    async def close(self) -> None:
        task, self._task = self._task, None
        await stop_task(task)

    def status(self) -> dict[str, Any]:
        return {}


class _Datagrams(asyncio.DatagramProtocol):
    def __init__(self) -> None:
        self.lost: asyncio.Future[str] = asyncio.get_running_loop().create_future()

    def error_received(self, exc: Exception) -> None:  # e.g. ICMP port unreachable: not fatal
        pass

    def connection_lost(self, exc: Exception | None) -> None:
        if not self.lost.done():
            self.lost.set_result(f"socket closed: {exc}" if exc else "socket closed")


class UdpSink(ByteSink):
    """Datagrams to one address (unicast or, with `broadcast`, a broadcast address)."""

    def __init__(self, settings: TransportSettings, health: ComponentHealth) -> None:
        super().__init__(settings, health, f"udp {settings.host}:{settings.port}")
        self._transport: asyncio.DatagramTransport | None = None

    async def _keep(self) -> None:
        s = self.settings

        async def opener() -> tuple[asyncio.DatagramTransport, _Datagrams]:
            loop = asyncio.get_running_loop()
            t, p = await loop.create_datagram_endpoint(
                _Datagrams, remote_addr=(s.host, s.port), allow_broadcast=s.broadcast, family=socket.AF_INET)
            return t, p

        async def session(conn: tuple[asyncio.DatagramTransport, _Datagrams]) -> None:
            self._transport = conn[0]
            try:
                raise LinkLost(await conn[1].lost)
            finally:
                self._transport = None

        async def close(conn: tuple[asyncio.DatagramTransport, _Datagrams]) -> None:
            conn[0].close()

        await self.link.run(opener, session, close)

    def send(self, data: bytes) -> bool:
        t = self._transport
        if t is None or t.is_closing():
            self.health.count("unsent.link_down")
            return False
        try:
            t.sendto(data)
        except OSError as exc:
            self.health.count("errors.send")
            self.health.error(f"udp send: {exc}")
            return False
        return True


class TcpServerSink(ByteSink):
    """A TCP server: every message to every client connected."""

    def __init__(self, settings: TransportSettings, health: ComponentHealth) -> None:
        super().__init__(settings, health, f"tcp server {settings.host}:{settings.port}")
        self._clients: set[asyncio.StreamWriter] = set()
        #: The port actually bound (port 0 in tests: the kernel's choice).
        self.bound_port: int | None = None
        self.listening = asyncio.Event()

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        h = self.health
        if len(self._clients) >= self.settings.max_clients:
            h.count("rejected.too_many_clients")
            writer.close()
            return
        self._clients.add(writer)
        h.count("clients_connected")
        try:
            while await reader.read(4096):  # what a client says is not read; EOF ends it
                pass
        except OSError:
            pass
        finally:
            self._clients.discard(writer)
            writer.close()

    async def _keep(self) -> None:
        s = self.settings

        async def opener() -> asyncio.Server:
            server = await asyncio.start_server(self._client, s.host, s.port, reuse_address=True)
            self.bound_port = self.health.info["port"] = server.sockets[0].getsockname()[1]
            self.listening.set()
            return server

        async def session(server: asyncio.Server) -> None:
            await server.serve_forever()

        async def close(server: asyncio.Server) -> None:
            self.listening.clear()
            server.close()
            for w in list(self._clients):
                w.close()
            self._clients.clear()

        await self.link.run(opener, session, close)

    def send(self, data: bytes) -> bool:
        if not self.listening.is_set():
            self.health.count("unsent.link_down")
            return False
        limit = self.settings.client_buffer
        for w in list(self._clients):
            t = w.transport
            if t.is_closing():
                self._clients.discard(w)
                continue
            if t.get_write_buffer_size() + len(data) > limit:
                self.health.count("dropped.slow_client")
                continue
            try:
                t.write(data)
            except OSError:
                self.health.count("errors.send")
                self._clients.discard(w)
                w.close()
        return True

    def status(self) -> dict[str, Any]:
        return {"clients": len(self._clients)}


class SerialSink(ByteSink):
    """A serial port, reopened with backoff when it goes (a USB adapter unplugged)."""

    def __init__(self, settings: TransportSettings, health: ComponentHealth) -> None:
        super().__init__(settings, health, f"serial {settings.device}")
        self._writer: asyncio.StreamWriter | None = None
        #: At most a second of the line's bytes wait (10 bits a byte): at 4800 Bd a
        #: heading must not reach the autopilot minutes late behind a backlog.
        self.line_buffer = min(settings.client_buffer, max(64, settings.baudrate // 10))

    async def _keep(self) -> None:
        s = self.settings

        async def opener() -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
            return await open_serial(s.device or "", s.baudrate)

        async def session(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter]) -> None:
            self._writer = conn[1]
            try:
                while await conn[0].read(4096):  # talkers on the line are not listened to
                    pass
                raise LinkLost("port closed")
            finally:
                self._writer = None

        async def close(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter]) -> None:
            conn[1].close()

        await self.link.run(opener, session, close)

    def send(self, data: bytes) -> bool:
        # (dropped.slow_client: the line is slower than the sentences)
        return write_bounded(self._writer, data, self.line_buffer, self.health, self.link.where)


def make_sink(settings: TransportSettings, health: ComponentHealth) -> ByteSink:
    """The sink of the configured transport."""
    kinds: dict[str, type[ByteSink]] = {"udp": UdpSink, "tcp": TcpServerSink, "serial": SerialSink}
    return kinds[settings.transport](settings, health)  # type: ignore[call-arg]
