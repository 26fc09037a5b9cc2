"""The edged input plugin `nmea0183` (entry point group `edged.inputs`)."""

from __future__ import annotations

import asyncio
from typing import Any, ClassVar

from edged.health import ComponentHealth
from edged.plugin import NO_MARKS, InputPlugin, OwnMarks, PluginContext
from edged.records import RawRecord

from . import PROTOCOL
from .config import Nmea0183Config
from .decoder import DecoderSettings, Nmea0183Decoder
from .framer import Framer
from .link import Sleep, TransportLink
from .logfile import meta_of
from .transports import make_transport


_LOSS_HINT = {
    "dropped.kernel": ": the socket's receive buffer was full (raise `rcvbuf`)",
    "dropped.queue": ": the queue to the framer was full (the event loop is too busy)",
}


class Nmea0183Input(InputPlugin):
    """NMEA 0183 from a serial port, a TCP multiplexer, UDP datagrams or a file."""

    Config: ClassVar[type[Nmea0183Config]] = Nmea0183Config
    protocol: ClassVar[str] = PROTOCOL
    description: ClassVar[str] = "NMEA 0183 sentences over serial, TCP, UDP or a file"

    def __init__(self, config: Nmea0183Config, ctx: PluginContext, *, sleep: Sleep = asyncio.sleep) -> None:
        super().__init__(config, ctx)
        self._sleep = sleep  # injectable: tests run the backoff without waiting
        self.transport = make_transport(config)

    async def run(self) -> None:
        cfg: Nmea0183Config = self.config
        ctx = self.ctx
        framer = Framer(ctx.health, cfg.checksum)
        now = ctx.clock.now
        ingest = ctx.ingest
        count = ctx.health.count
        source = ctx.name
        datagrams = self.transport.message_oriented

        def emit(framed: list) -> None:
            for fr in framed:
                count("accepted")
                ingest(RawRecord(PROTOCOL, source, now(), fr.sentence, meta_of(fr)))

        def on_data(chunk: bytes) -> None:
            emit(framer.feed(chunk))
            if datagrams:
                emit(framer.flush())  # a datagram's last line needs no line end

        def on_end() -> None:
            # A file's last line may lack its line end; a broken connection's partial
            # line is a fragment and is dropped.
            if self.transport.finite:
                emit(framer.flush())
            framer.reset()

        link = TransportLink(
            self.transport,
            ctx.health,
            watchdog=cfg.watchdog,
            backoff=cfg.backoff(),
            sleep=self._sleep,
        )
        await link.run(on_data, on_end)
        await asyncio.Event().wait()  # a finished file: stay until cancelled, as run() must

    def status(self) -> dict[str, Any]:
        """Copy the transport's loss counters into health (at every health snapshot).

        The counters are running totals kept by the transport across reopens and
        restarts of `run`; a loss is also the component's last error, logged once per
        change of message. The state stays the link's: a link that loses part of a
        flood still delivers, and `rates` in health shows how much it loses.
        """
        t = self.transport
        h = self.ctx.health
        counters = h.counters
        for key, total in t.counters().items():
            before = counters.get(key, 0)
            if total > before or key not in counters:
                counters[key] = max(total, before)
            if total > before:
                h.error(f"{t.describe()}: data lost before framing ({key}){_LOSS_HINT.get(key, '')}")
        return t.info()

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth, own: OwnMarks = NO_MARKS) -> Nmea0183Decoder:
        return Nmea0183Decoder(source, health, DecoderSettings.from_config(config, own))
