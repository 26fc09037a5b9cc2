"""The `n2k_gateway` input: NMEA 2000 from a gateway, over TCP, UDP or a serial port.

Most vessels reach NMEA 2000 through a gateway, not a bare CAN interface: a Yacht
Devices YDEN-02/YDWG-02 speaks its RAW format over TCP or UDP; an Actisense NGT-1/NGX
its binary BST over USB serial (`actisense_bst`) or, set so, N2K ASCII
(`actisense_ascii`); a Digital Yacht iKonvert its `!PDGY` lines over USB serial;
canboat's `actisense-serial` relays plain text; SeaSmart and MiniPlex gateways wrap
messages in `$PCDIN`/`$MXPGN` sentences. Each message becomes a raw record holding
the gateway's own bytes (a line; a BST message with its framing) and its format
(`{"format": <gateway>}`), stamped with the clock, and goes through the very decoder a
log of the same format replays through (`formats`, `decoder.CanDecoder`): the same
measurements, sources and counters as a bus.

Links are kept open like every other input's (`edged.link`): reconnect with backoff, a
watchdog for a silent gateway. A message cut by a dropped connection is counted
(`partial_lines`, `partial_messages` for BST) and never joined to the next
connection's bytes; a line longer than `max_line` is `rejected.too_long`.

Start-up (`handshake`, on by default on a serial port): an NGT-1 forwards nothing
until told to, an iKonvert stays off the bus until a client puts it on. The
conversation is the `nmea2000` package's (its canboat `GatewayCodec`, "ngt1" and
"ikonvert"): its opening bytes are written at each connect, what it answers to the
gateway's replies and its timers is written back; the frames it decodes are not used
(ours come from `formats`, with a count per reason).
"""

from __future__ import annotations

import asyncio
from typing import Any, ClassVar, Literal, Protocol

from pydantic import Field, ValidationInfo, field_validator

from edged.config import MAX_WATCHDOG, ReconnectSettings
from edged.health import ComponentHealth
from edged.link import Link, LinkLost, LinkStale
from edged.plugin import NO_MARKS, Claim, InputConfig, InputPlugin, OwnMarks, PluginContext, listen_claim, serial_claim
from edged.records import RawRecord

from .config import default_config
from .formats.actisense_bst import Deframer

#: The gateway formats a live stream may carry (their framers in `formats`).
Gateway = Literal["ydwg_raw", "actisense_plain", "actisense_ascii", "actisense_bst", "ikonvert", "pcdin", "mxpgn"]
#: Serial speed of each gateway's USB port when the configuration names none.
DEFAULT_BAUD = {"actisense_bst": 115200, "actisense_ascii": 115200, "ikonvert": 230400}
#: Gateways with a start-up conversation: the `nmea2000` package's codec of each.
HANDSHAKES = {"actisense_bst": "ngt1", "ikonvert": "ikonvert"}


class GatewayConfig(InputConfig, ReconnectSettings):
    #: The gateway's format (what its stream carries).
    gateway: Gateway
    transport: Literal["tcp", "udp", "serial"]
    #: TCP: the gateway's address (YDWG-02 default port 1457 for RAW).
    host: str | None = Field(None, validate_default=True)
    port: int | None = Field(None, ge=1, le=65535, validate_default=True)
    #: UDP: the local address to listen on (loopback unless told otherwise).
    bind: str = "127.0.0.1"
    #: Serial: the device (`/dev/ttyUSB0`, or a pyserial URL) and its speed (Bd;
    #: default 115200, iKonvert 230400).
    device: str | None = Field(None, validate_default=True)
    baudrate: int | None = Field(None, gt=0, le=4_000_000, validate_default=True)
    #: Send the gateway's start-up commands at each connect (NGT-1: receive all;
    #: iKonvert: go on the bus). Default: on for a serial port, off for TCP/UDP (a
    #: relay in between usually did it).
    handshake: bool | None = Field(None, validate_default=True)
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

    @field_validator("port")
    @classmethod
    def _port_for_sockets(cls, v: int | None, info: ValidationInfo) -> int | None:
        if info.data.get("transport") in ("tcp", "udp") and v is None:
            raise ValueError(f"required when transport is {info.data.get('transport')!r}")
        return v

    @field_validator("device")
    @classmethod
    def _device_for_serial(cls, v: str | None, info: ValidationInfo) -> str | None:
        if info.data.get("transport") == "serial" and not v:
            raise ValueError("required when transport is 'serial'")
        return v

    @field_validator("baudrate")
    @classmethod
    def _baud_of_gateway(cls, v: int | None, info: ValidationInfo) -> int:
        return v if v is not None else DEFAULT_BAUD.get(info.data.get("gateway", ""), 115200)

    @field_validator("handshake")
    @classmethod
    def _handshake_on_serial(cls, v: bool | None, info: ValidationInfo) -> bool:
        if v and info.data.get("gateway") not in HANDSHAKES:
            raise ValueError(f"only {' and '.join(sorted(HANDSHAKES))} have a start-up conversation")
        if v is not None:
            return v
        return info.data.get("transport") == "serial" and info.data.get("gateway") in HANDSHAKES

    def claims(self) -> list[Claim]:
        if self.transport == "udp":
            return [listen_claim("port", "udp", self.bind, self.port)]
        if self.transport == "serial" and self.device:
            return serial_claim(self.device, text=f"read serial {self.device}")
        return []

    def where(self) -> str:
        if self.transport == "serial":
            return f"serial {self.device} @ {self.baudrate} Bd"
        if self.transport == "udp":
            return f"udp {self.bind}:{self.port}"
        return f"tcp {self.host}:{self.port}"


class Framing(Protocol):
    """Bytes of one connection -> the gateway's messages (`feed`); `end` counts a cut one."""

    def feed(self, data: bytes) -> list[bytes]: ...

    def end(self) -> None: ...


class Handshake:
    """A gateway's start-up and keep-alive conversation, by the `nmea2000` package's
    canboat codec: `open()` the bytes to send at connect, `answer(data)` /
    `tick()` what to send back (b"" when nothing). Its decoded frames are dropped:
    ours come from `formats`."""

    def __init__(self, gateway: str, clock: Any) -> None:
        from nmea2000 import _canboat

        self._codec = _canboat.GatewayCodec(HANDSHAKES[gateway])  # type: ignore[arg-type]
        self._clock = clock

    def _ms(self) -> int:
        return int(self._clock.now() * 1000)

    def open(self) -> bytes:
        return self._codec.open()

    def _sends(self, events: list[Any]) -> bytes:
        return b"".join(p for kind, p in events if kind == "send")

    def answer(self, data: bytes) -> bytes:
        return self._sends(self._codec.receive(data, self._ms()))

    def tick(self) -> bytes:
        return self._sends(self._codec.tick(self._ms()))


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


Streams = tuple[asyncio.StreamReader, asyncio.StreamWriter]


class GatewayInput(InputPlugin):
    Config: ClassVar[type[GatewayConfig]] = GatewayConfig
    protocol: ClassVar[str] = "can"
    description: ClassVar[str] = (
        "NMEA 2000 from a gateway (YDWG RAW, Actisense BST/ASCII/plain, iKonvert, PCDIN, MXPGN) "
        "over TCP, UDP or a serial port"
    )

    def __init__(self, config: GatewayConfig, ctx: PluginContext, *, sleep: Any = asyncio.sleep) -> None:
        super().__init__(config, ctx)
        self._sleep = sleep
        self._counter = "bst_messages" if config.gateway == "actisense_bst" else "lines"

    def _framing(self) -> Framing:
        if self.config.gateway == "actisense_bst":
            return Deframer(self.ctx.health)
        return _Lines(self.ctx.health, self.config.max_line)

    def _emit(self, messages: list[bytes]) -> None:
        ctx = self.ctx
        meta = {"format": self.config.gateway}
        now = ctx.clock.now
        count = ctx.health.count
        for msg in messages:
            count(self._counter)
            ctx.ingest(RawRecord("can", ctx.name, now(), msg, meta))

    async def _open_stream(self) -> Streams:
        cfg: GatewayConfig = self.config
        if cfg.transport == "tcp":
            return await asyncio.open_connection(cfg.host, cfg.port)
        # Opened without flushing what the adapter already received, pyserial URLs
        # accepted (the NMEA 0183 input's serial port too).
        from edged.serialport import open_serial

        return await open_serial(cfg.device or "", cfg.baudrate or 115200)

    async def _stream_session(self, link: Link[Any], conn: Streams) -> None:
        cfg: GatewayConfig = self.config
        h = self.ctx.health
        reader, writer = conn
        framing = self._framing()
        hs = Handshake(cfg.gateway, self.ctx.clock) if cfg.handshake else None

        async def send(data: bytes) -> None:
            if data:
                writer.write(data)
                await writer.drain()
                h.count("bytes_sent", len(data))

        clock = asyncio.get_running_loop().time
        since = clock()  # when a frame was last decoded (or the session began)
        frames = h.counters.get("frames", 0)
        try:
            if hs is not None:
                await send(hs.open())
            while True:
                try:
                    data = await asyncio.wait_for(reader.read(65536), cfg.watchdog)
                except asyncio.TimeoutError:
                    raise LinkStale(f"no data for {cfg.watchdog:g} s") from None
                if not data:
                    raise LinkLost("closed by the gateway")
                h.count("bytes", len(data))
                self._emit(framing.feed(data))
                if h.counters.get("frames", 0) != frames:  # the decoder took a frame
                    frames, since = h.counters.get("frames", 0), clock()
                    link.stable()
                elif clock() - since > cfg.watchdog:
                    # bytes but no frame (garbage, an endless line, the wrong baud
                    # rate): as good as silence, not `connected` and ok (issue 32)
                    raise LinkStale(f"no frame for {cfg.watchdog:g} s while bytes arrive "
                                    f"(see the rejected.* counters)")
                if hs is not None:
                    await send(hs.answer(data) + hs.tick())
        finally:
            framing.end()

    async def run(self) -> None:
        cfg: GatewayConfig = self.config
        h = self.ctx.health
        if cfg.transport != "udp":
            link: Link[Any] = Link(h, cfg.backoff(), where=cfg.where(), sleep=self._sleep)

            async def session(conn: Streams) -> None:
                await self._stream_session(link, conn)

            async def close(conn: Streams) -> None:
                conn[1].close()

            await link.run(self._open_stream, session, close)
            return
        link = Link(h, cfg.backoff(), where=cfg.where(), sleep=self._sleep)
        plugin = self

        class _Proto(asyncio.DatagramProtocol):
            def __init__(self) -> None:
                self.got = asyncio.Event()

            def datagram_received(self, data: bytes, addr: Any) -> None:
                h.count("bytes", len(data))
                self.got.set()
                framing = plugin._framing()  # a datagram is whole: nothing carries over
                if isinstance(framing, _Lines):
                    data += b"\n"  # its last line needs no line end
                plugin._emit(framing.feed(data))
                framing.end()

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
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth, own: OwnMarks = NO_MARKS) -> Any:
        from .decoder import CanDecoder

        return CanDecoder(source, default_config(), health, own)  # a bus's decoder, as for a log
