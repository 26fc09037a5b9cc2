"""The `can` input plugin: live buses and the per-bus decoder (its log readers, candump
and the gateway formats, are in `logs`)."""

from __future__ import annotations

import asyncio
from typing import TYPE_CHECKING, Any, Callable, ClassVar

from edged.health import ComponentHealth
from edged.link import Link, LinkLost
from edged.plugin import NO_MARKS, InputPlugin, OwnMarks, PluginContext
from edged.records import RawRecord

from .config import CanConfig, default_config

if TYPE_CHECKING:
    # python-can (the live bus) and the decoder (cantools, nmea2000) are imported when
    # a bus is opened or a decoder made, not when this class is loaded.
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
        """Keep the bus open (`edged.link`): `connected` while frames can flow; a bus
        error, a bus-off or silence longer than the watchdog ends the session and the
        bus is reopened after the backoff (`stale` first for the watchdog)."""
        from .bus import pump

        cfg: CanConfig = self.config
        health = self.ctx.health
        link: Link[can.BusABC] = Link(
            health,
            cfg.backoff(),
            where=f"{cfg.interface} bus {cfg.channel!r}",
            sleep=self.sleep,
            open_errors=_open_errors(),
            link_errors=(),  # the pump turns every bus failure into a LinkLost
        )

        async def open_bus() -> can.BusABC:
            return self.open_bus(interface=cfg.interface, channel=cfg.channel, bitrate=cfg.bitrate)

        async def session(bus: can.BusABC) -> None:
            self.sessions += 1
            self._session_frames = 0
            try:
                await pump(bus, self._on_frame, health, cfg.watchdog)
            except LinkLost as exc:
                health.error(f"{cfg.channel}: {exc}; reopening")
                raise
            finally:
                if self._session_frames:
                    link.stable()  # frames had flowed: the backoff starts over

        async def shutdown(bus: can.BusABC) -> None:
            bus.shutdown()

        await link.run(open_bus, session, shutdown)

    def _on_frame(self, msg: can.Message) -> None:
        self._session_frames += 1
        ctx = self.ctx
        meta: dict[str, Any] = {"id": msg.arbitration_id, "ext": bool(msg.is_extended_id)}
        if msg.is_fd:  # the decoder allows an FD frame up to 64 bytes, a classic one 8
            meta["fd"] = True
        ctx.ingest(RawRecord("can", ctx.name, ctx.clock.now(), bytes(msg.data), meta))

    def status(self) -> dict[str, Any]:
        return {"interface": self.config.interface, "channel": self.config.channel, "sessions": self.sessions}

    @classmethod
    def make_decoder(cls, source: str, config: Any, health: ComponentHealth, own: OwnMarks = NO_MARKS) -> CanDecoder:
        from .decoder import CanDecoder

        return CanDecoder(source, config if isinstance(config, CanConfig) else default_config(), health, own)
