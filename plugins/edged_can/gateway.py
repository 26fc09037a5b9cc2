"""The `n2k_gateway` input: NMEA 2000 from a gateway's text stream over TCP or UDP.

Most vessels reach NMEA 2000 through a gateway, not a bare CAN interface: a Yacht
Devices YDEN-02/YDWG-02 speaks its RAW format over TCP or UDP, an Actisense or a
canboat `actisense-serial` relay its plain text, a SeaSmart or MiniPlex gateway wraps
messages in `$PCDIN`/`$MXPGN` sentences. Each line becomes a raw record holding the
gateway's own bytes and its format (`{"format": <gateway>}`), stamped with the clock,
and goes through the very decoder a log of the same format replays through
(`formats`, `decoder.CanDecoder`): same measurements, sources and counters as a bus.

Links are kept open like every other input's (`edged.link`): reconnect with backoff, a
watchdog for a silent gateway. A line cut by a dropped connection is counted
`partial_lines` and never joined to the next connection's bytes; a line longer than
`max_line` is `rejected.too_long`.
"""

from __future__ import annotations

import asyncio
from typing import Any, BinaryIO, ClassVar, Iterator, Literal

from pydantic import Field, ValidationInfo, field_validator

from edged.config import MAX_WATCHDOG, ReconnectSettings
from edged.health import ComponentHealth
from edged.link import Link, LinkLost, LinkStale
from edged.plugin import Claim, InputConfig, InputPlugin, PluginContext, ReplayOptions
from edged.records import RawRecord

from .config import default_config

#: The gateway formats a live stream may carry (their framers in `formats`).
Gateway = Literal["ydwg_raw", "actisense_plain", "ikonvert", "pcdin", "mxpgn"]


class GatewayConfig(InputConfig, ReconnectSettings):
    #: The gateway's format (what its stream carries).
    gateway: Gateway
    transport: Literal["tcp", "udp"]
    #: TCP: the gateway's address (YDWG-02 default port 1457 for RAW).
    host: str | None = Field(None, validate_default=True)
    port: int = Field(ge=1, le=65535)
    #: UDP: the local address to listen on (loopback unless told otherwise).
    bind: str = "127.0.0.1"
    #: Seconds without a byte before the link is reopened.
    watchdog: float = Field(10.0, gt=0, le=MAX_WATCHDOG)
    #: Longest line accepted, bytes (a 223-byte message in plain text is ~700).
    max_line: int = Field(2048, ge=64, le=65536)

    @field_validator("host")
    @classmethod
    def _host_for_tcp(cls, v: str | None, info: ValidationInfo) -> str | None:
        if info.data.get("transport") == "tcp" and not v:
            raise ValueError("required when transport is 'tcp'")
        return v

    def claims(self) -> list[Claim]:
        if self.transport == "udp":
            host = "*" if self.bind in ("0.0.0.0", "::", "") else self.bind
            return [Claim("port", ("udp", host, str(self.port)), f"listen on udp {self.bind}:{self.port}")]
        return []


class _Lines:
    """Bytes -> whole lines of one connection; what is left when it ends is partial."""

    def __init__(self, health: ComponentHealth, max_line: int) -> None:
        self.buf = b""
        self.health = health
        self.max_line = max_line
        self.skipping = False  # the rest of an over-long line is dropped up to its end

    def feed(self, data: bytes) -> list[bytes]:
        self.buf += data
        *lines, self.buf = self.buf.split(b"\n")
        if self.skipping and lines:
            lines = lines[1:]  # the tail of the over-long line
            self.skipping = False
        if len(self.buf) > self.max_line:
            self.health.count("rejected.too_long")
            self.buf = b""
            self.skipping = True
        out = []
        for ln in lines:
            ln = ln.strip()
            if not ln:
                continue
            if len(ln) > self.max_line:
                self.health.count("rejected.too_long")
                continue
            out.append(ln)
        return out

    def end(self) -> None:
        if self.buf.strip():
            self.health.count("partial_lines")
        self.buf = b""
        self.skipping = False


class GatewayInput(InputPlugin):
    Config: ClassVar[type[GatewayConfig]] = GatewayConfig
    protocol: ClassVar[str] = "can"
    description: ClassVar[str] = "NMEA 2000 from a gateway (YDWG RAW, Actisense plain, iKonvert, PCDIN, MXPGN) over TCP or UDP"

    def __init__(self, config: GatewayConfig, ctx: PluginContext, *, sleep: Any = asyncio.sleep) -> None:
        super().__init__(config, ctx)
        self._sleep = sleep

    def _emit(self, lines: list[bytes]) -> None:
        ctx = self.ctx
        meta = {"format": self.config.gateway}
        now = ctx.clock.now
        for ln in lines:
            ctx.health.count("lines")
            ctx.ingest(RawRecord("can", ctx.name, now(), ln, meta))

    async def run(self) -> None:
        cfg: GatewayConfig = self.config
        h = self.ctx.health
        if cfg.transport == "tcp":
            where = f"tcp {cfg.host}:{cfg.port}"
            link: Link[Any] = Link(h, cfg.backoff(), where=where, sleep=self._sleep)

            async def open_tcp() -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
                return await asyncio.open_connection(cfg.host, cfg.port)

            async def session(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter]) -> None:
                reader, _ = conn
                lines = _Lines(h, cfg.max_line)
                try:
                    while True:
                        try:
                            data = await asyncio.wait_for(reader.read(65536), cfg.watchdog)
                        except asyncio.TimeoutError:
                            raise LinkStale(f"no data for {cfg.watchdog:g} s") from None
                        if not data:
                            raise LinkLost("closed by the gateway")
                        h.count("bytes", len(data))
                        link.stable()
                        self._emit(lines.feed(data))
                finally:
                    lines.end()

            async def close(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter]) -> None:
                conn[1].close()

            await link.run(open_tcp, session, close)
        else:
            where = f"udp {cfg.bind}:{cfg.port}"
            link = Link(h, cfg.backoff(), where=where, sleep=self._sleep)
            plugin = self

            class _Proto(asyncio.DatagramProtocol):
                def __init__(self) -> None:
                    self.got = asyncio.Event()

                def datagram_received(self, data: bytes, addr: Any) -> None:
                    h.count("bytes", len(data))
                    self.got.set()
                    lines = _Lines(h, cfg.max_line)
                    out = lines.feed(data + b"\n")  # a datagram's last line needs no line end
                    plugin._emit(out)

            async def open_udp() -> tuple[asyncio.DatagramTransport, _Proto]:
                loop = asyncio.get_running_loop()
                return await loop.create_datagram_endpoint(_Proto, local_addr=(cfg.bind, cfg.port))

            async def udp_session(conn: tuple[asyncio.DatagramTransport, _Proto]) -> None:
                proto = conn[1]
                while True:
                    proto.got.clear()
                    try:
                        await asyncio.wait_for(proto.got.wait(), cfg.watchdog)
                    except asyncio.TimeoutError:
                        raise LinkStale(f"no datagram for {cfg.watchdog:g} s") from None
                    link.stable()

            async def udp_close(conn: tuple[asyncio.DatagramTransport, _Proto]) -> None:
                conn[0].close()

            await link.run(open_udp, udp_session, udp_close)

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth) -> Any:
        from .decoder import CanDecoder

        return CanDecoder(source, default_config(), health)  # a bus's decoder, as for a log

    @classmethod
    def sniff(cls, head: bytes) -> bool:
        return False  # logs of these formats are the `can` input's (formats/)

    @classmethod
    def open_replay(cls, stream: BinaryIO, source: str, health: ComponentHealth,
                    options: ReplayOptions) -> Iterator[RawRecord]:
        return iter(())
