"""The `nmea2000` output: the fused values as NMEA 2000 PGNs (DESIGN §2 "Outputs").

PGNs 128259, 130577, 127250, 127251, 128000 and 129026 (`pgns`), each at its own rate
of data time (`rates`, by PGN number), made from the latest estimates (`BridgeView`:
what is stale or converging goes out as "no data"). On a CAN bus (`transport =
"can"`) edged is a device of its own: it claims an address with its NAME, answers
requests and beats (`citizen`); through a gateway (`ydwg`, `actisense`) the gateway
is the device and sends with its own address, so nothing is claimed.

Health: `sent` (messages made and handed to the link), `unsent.link_down`,
`unsent.no_address` (no address claimed yet, or lost and not yet claimed again),
`dropped.slow_link`, `errors.send`, `errors.encode`, `address_claims`,
`address_lost`, `requests_answered`, `heartbeats`; info: `address` (the one we send
from; None while none is ours), `address_state`, `link`.

Own marks (`own_marks`): our NAME, `n2k.name` -> {16 hex digits}; every CAN decoder
of edged refuses frames from the address that NAME claimed (`rejected.own_output`).
"""

from __future__ import annotations

import asyncio
from typing import Any, ClassVar

from edged.link import stop_task
from edged.plugin import PluginContext
from edged.bridgeoutput import BridgeOutput, Message

from . import wire
from .citizen import Citizen, name_of
from .config import WATER_REFERENCE, Nmea2000OutputConfig
from .links import N2kLink, make_link
from .marks import OWN_GATEWAY_TX, OWN_NAME, name_hex
from .pgns import PGNS, Sid, fields_of
from .wire import Frame

__all__ = ["Nmea2000Output"]

#: Seconds between the checks of the claim's deadlines and the heartbeat (of real time;
#: what is due is judged by the clock).
TICK = 0.05


class Nmea2000Output(BridgeOutput):
    """NMEA 2000 PGNs of the fused values (128259, 130577, 127250, 127251, 128000,
    129026) on a CAN bus, where edged claims an address, answers requests and beats,
    or through a YDWG-02 (RAW over TCP) or Actisense NGT-1 (BST) gateway."""

    Config: ClassVar[type[Nmea2000OutputConfig]] = Nmea2000OutputConfig
    description: ClassVar[str] = "NMEA 2000 PGNs of the fused values on a CAN bus or through a gateway"
    messages: ClassVar[tuple[Message, ...]] = tuple(p.message for p in PGNS.values())

    def __init__(self, config: Nmea2000OutputConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        self._sid = Sid()
        self._options = {"stw_sensor_type": WATER_REFERENCE.get(config.stw_sensor_type or "")}
        tx = tuple(int(n) for n in PGNS)
        self.link: N2kLink = make_link(config, ctx.health)
        self.citizen: Citizen | None = None
        if config.transport == "can":
            self.citizen = Citizen(config, ctx.health, self._send_as_is, tx)
            self.link.on_frame = self._on_frame
        self._ticker: asyncio.Task[None] | None = None

    @classmethod
    def own_marks(cls, config: Any) -> dict[str, frozenset[str]]:
        """Our NAME, whatever the transport: a gateway's own claim is not ours, but
        a bus we also read may carry our claim (`can`). Through a YDWG, also the PGNs
        it sends: the gateway echoes them as its own transmissions (`T` lines)."""
        marks = {OWN_NAME: frozenset({name_hex(name_of(config))})}
        if config.transport == "ydwg":
            sent = (m.name for m in cls.messages if float(config.rates.get(m.name, m.hz)) > 0)
            marks[OWN_GATEWAY_TX] = frozenset(sent)
        return marks

    # -- lifecycle --------------------------------------------------------------------
    async def open(self) -> None:
        await self.link.open()
        if self.citizen is not None and self._ticker is None:
            self._ticker = asyncio.get_running_loop().create_task(self._tick_loop(), name=f"{self.ctx.name} n2k claim")

    async def close(self) -> None:
        ticker, self._ticker = self._ticker, None
        await stop_task(ticker)
        await self.link.close()

    async def _tick_loop(self) -> None:
        """Claim at each (re)connect of the bus, then keep the claim's deadlines and
        the heartbeat; a failure here is logged and the loop goes on."""
        citizen, link, clock = self.citizen, self.link, self.ctx.clock
        assert citizen is not None
        while True:
            await link.connected.wait()
            step = citizen.start
            while link.connected.is_set():
                try:
                    step(clock.monotonic())
                except Exception as exc:  # canboat's state machine: never stop the output
                    self.ctx.health.count("errors.claim")
                    self.ctx.health.error(f"address claim: {type(exc).__name__}: {exc}")
                step = citizen.tick
                await asyncio.sleep(TICK)

    # -- what goes out ----------------------------------------------------------------
    def _on_frame(self, pgn: int, src: int, dst: int, data: bytes) -> None:
        assert self.citizen is not None
        try:
            self.citizen.on_frame(self.ctx.clock.monotonic(), pgn, src, dst, data)
        except Exception as exc:  # a frame the state machine chokes on: counted, not raised
            self.ctx.health.count("errors.claim")
            self.ctx.health.error(f"frame PGN {pgn} from {src}: {type(exc).__name__}: {exc}")

    def _send_as_is(self, frame: Frame) -> None:
        self.link.send(frame)

    def encode(self, name: str) -> Frame | None:
        pgn = PGNS[name]
        fields = fields_of(pgn, self.view, self._sid.at(self.view.t), self._options)
        try:
            payload = wire.encode(int(name), fields)
        except (wire.EncodeError, ValueError, KeyError) as exc:
            self.ctx.health.count("errors.encode")
            self.ctx.health.error(f"PGN {name}: {exc}")
            return None
        return Frame(pgn.prio, int(name), self.config.address, 255, payload)

    def linked(self) -> bool:
        """The bus or gateway is open. Not the address: its claim runs on the clock,
        which in a replay is the data's, so the first second of a replay goes before
        an address is held (`unsent.no_address`)."""
        return self.link.connected.is_set()

    def deliver(self, name: str, payload: Frame) -> bool:
        if self.citizen is not None:
            addr = self.citizen.address
            if addr is None:
                up = self.link.connected.is_set()
                self.ctx.health.count("unsent.no_address" if up else "unsent.link_down")
                return False
            payload = payload._replace(src=addr)
        return self.link.send(payload)

    def link_problems(self) -> list[str]:
        problems = super().link_problems()
        if not problems and self.citizen is not None and self.citizen.address is None:
            problems.append("not delivering: no address of its own on the bus (claiming, or none free)")
        return problems

    def status(self) -> dict[str, Any]:
        super().status()
        return {"transport": self.config.transport, "where": self.config.where()}
