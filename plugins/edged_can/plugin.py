"""The `can` input plugin: live buses, candump replay, and the per-bus decoder."""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any, BinaryIO, Callable, ClassVar, Iterator

from edged.health import ComponentHealth
from edged.plugin import InputPlugin, PluginContext, ReplayOptions
from edged.records import RawRecord

from . import candump
from .config import CanConfig, default_config

if TYPE_CHECKING:
    # python-can (the live bus) and the decoder (cantools, nmea2000) are imported when
    # a bus is opened or a decoder made, not when `edged replay` loads this class only
    # to ask whether it reads an NMEA 0183 log.
    import can

    from .bus import Sleep
    from .decoder import CanDecoder


def _open_errors() -> tuple[type[BaseException], ...]:
    """What python-can raises when a bus cannot be opened (missing interface, no driver)."""
    import can

    return (can.CanError, OSError, ValueError, NotImplementedError)


class CanInput(InputPlugin):
    """NMEA 2000 and DBC frames from a SocketCAN or virtual bus (DESIGN §5)."""

    Config: ClassVar[type[CanConfig]] = CanConfig
    protocol: ClassVar[str] = "can"
    description: ClassVar[str] = "CAN bus: NMEA 2000 PGNs and DBC-described sensor frames"

    def __init__(self, config: CanConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        import can

        #: How a bus is opened and how the backoff waits; tests replace both.
        self.open_bus: Callable[..., can.BusABC] = can.Bus
        self.sleep: Sleep = asyncio.sleep
        self.sessions = 0
        self._session_frames = 0

    async def run(self) -> None:
        from .bus import SessionEnded, pump

        cfg: CanConfig = self.config
        health = self.ctx.health
        open_errors = _open_errors()
        backoff = cfg.backoff()
        while True:
            health.set_state("connecting")
            try:
                bus = self.open_bus(interface=cfg.interface, channel=cfg.channel, bitrate=cfg.bitrate)
            except open_errors as exc:
                health.count("bus.open_failed")
                health.error(f"cannot open {cfg.interface} bus {cfg.channel!r}: {exc}")
                health.set_state("reconnecting")
                await self.sleep(backoff.next_delay())
                continue
            self.sessions += 1
            self._session_frames = 0
            health.set_state("running")
            try:
                await pump(bus, self._on_frame, health, cfg.watchdog)
            except SessionEnded as exc:
                health.error(f"{cfg.channel}: {exc}; reopening")
            finally:
                bus.shutdown()
            health.count("bus.reopen")
            if self._session_frames:
                backoff.reset()
            if health.state != "bus_off":
                health.set_state("reconnecting")
            await self.sleep(backoff.next_delay())

    def _on_frame(self, msg: can.Message) -> None:
        self._session_frames += 1
        ctx = self.ctx
        ctx.ingest(
            RawRecord(
                "can",
                ctx.name,
                ctx.clock.now(),
                bytes(msg.data),
                {"id": msg.arbitration_id, "ext": bool(msg.is_extended_id)},
            )
        )

    def status(self) -> dict[str, Any]:
        return {"interface": self.config.interface, "channel": self.config.channel, "sessions": self.sessions}

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth) -> CanDecoder:
        from .decoder import CanDecoder

        return CanDecoder(source, config if isinstance(config, CanConfig) else default_config(), health)

    @classmethod
    def sniff(cls, head: bytes) -> bool:
        return candump.sniff(head)

    @classmethod
    def open_replay(
        cls, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        # Without a configuration section for this file, the bus is the interface the
        # log names, so files of one bus share one decoder (and their fast-packets).
        return candump.read(stream, source, health, bus_from_line=options.config is None)
