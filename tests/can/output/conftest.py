"""The NMEA 2000 output's test rig: an output on a python-can `virtual` bus, a peer on
the same bus that hears and sends frames, a manual clock, and estimates.

Frames the output sends are decoded by the `nmea2000` package's own decoder (its
fast-packet reassembly included), independent of the encoder path the output uses.
Time moves only by `clock.step`; every wait is for a frame, bounded by `wait_for`.
"""

from __future__ import annotations

import asyncio
import itertools
from typing import Any, AsyncIterator, Callable

import can
import pytest
from nmea2000 import NMEA2000Decoder

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.records import Estimate
from edged_can.formats import can_id
from edged_can.output.config import Nmea2000OutputConfig
from edged_can.output.plugin import Nmea2000Output

WAIT = 5.0
_channels = itertools.count()
T0 = 1_700_000_000.0


def split(ident: int) -> tuple[int, int, int, int]:
    """(prio, pgn, src, dst) of an identifier, written out (PDU1 / PDU2)."""
    pf, ps = (ident >> 16) & 0xFF, (ident >> 8) & 0xFF
    pgn = (ident >> 8) & (0x3FF00 if pf < 240 else 0x3FFFF)
    return (ident >> 26) & 7, pgn, ident & 0xFF, ps if pf < 240 else 255


def stw_est(t: float, **values: Any) -> Estimate:
    v = {"stw": 4.12, "current": 0.37, "current_set": 2.5, "sog": 4.3, "stale": False, "converging": False}
    v.update(values)
    return Estimate("stw", "stw", t, v, "stw")


def man_est(t: float, **values: Any) -> Estimate:
    v = {"heading": 1.2345, "r": -0.0123456, "sog": 4.31, "cog": 1.3, "drift_angle_water": -0.0456,
         "stale": False, "converging": False}
    v.update(values)
    return Estimate("manoeuvre", "manoeuvre", t, v, "manoeuvre")


class Peer:
    """Another node on the bus: receives every frame, decodes them, sends its own."""

    def __init__(self, channel: str) -> None:
        self.bus = can.Bus(interface="virtual", channel=channel)
        self.reader = can.AsyncBufferedReader()
        self.notifier = can.Notifier(self.bus, [self.reader], timeout=0.05, loop=asyncio.get_running_loop())
        self.decoder = NMEA2000Decoder(units="si")
        self.frames: list[can.Message] = []

    async def frame(self, pgn: int | None = None, src: int | None = None) -> can.Message:
        """The next frame (of `pgn`, from `src`), others skipped."""
        while True:
            msg = await asyncio.wait_for(self.reader.get_message(), WAIT)
            self.frames.append(msg)
            _, p, s, _ = split(msg.arbitration_id)
            if (pgn is None or p == pgn) and (src is None or s == src):
                return msg

    async def message(self, pgn: int, src: int | None = None) -> Any:
        """The next whole message of `pgn`, decoded by the nmea2000 package."""
        while True:
            msg = await self.frame(pgn, src)
            decoded = self.decoder.decode(msg)
            if decoded is not None:
                return decoded

    async def messages(self, wanted: set[int], src: int | None = None) -> dict[int, list[Any]]:
        """Every whole message (decoded by the nmea2000 package) by PGN, until each
        PGN of `wanted` came at least once (from `src`)."""
        got: dict[int, list[Any]] = {}
        while not wanted <= got.keys():
            msg = await self.frame(src=src)
            decoded = self.decoder.decode(msg)
            if decoded is not None:
                got.setdefault(decoded.PGN, []).append(decoded)
        return got

    def send(self, prio: int, pgn: int, src: int, dst: int, data: bytes) -> None:
        self.bus.send(can.Message(arbitration_id=can_id(prio, pgn, src, dst), data=data, is_extended_id=True))

    def close(self) -> None:
        self.notifier.stop(timeout=1.0)
        self.bus.shutdown()


class Rig:
    def __init__(self, clock: ManualClock, out: Nmea2000Output, peer: Peer) -> None:
        self.clock, self.out, self.peer = clock, out, peer
        self.health = out.ctx.health

    async def claimed(self) -> int:
        """Start the claim (the bus is asked for claims), let the scan and the claim
        time pass on the clock; the address we then send a heartbeat from."""
        await asyncio.wait_for(self.out.link.connected.wait(), WAIT)
        await self.peer.frame(59904)  # the request for everyone's claims
        self.clock.step(1.0)
        claim = await self.peer.frame(60928)
        self.clock.step(0.3)
        beat = await self.peer.frame(126993)
        assert split(beat.arbitration_id)[2] == split(claim.arbitration_id)[2]
        return split(beat.arbitration_id)[2]


def fields(msg: Any) -> dict[str, Any]:
    return {f.id: f.value for f in msg.fields}


@pytest.fixture
async def make_rig() -> AsyncIterator[Callable[..., Any]]:
    made: list[Rig] = []

    async def _make(**cfg: Any) -> Rig:
        channel = f"n2k-out-{next(_channels)}"
        clock = ManualClock(T0)
        health = ComponentHealth("n2k", "output", "nmea2000", clock)
        ctx = PluginContext("n2k", clock, health, lambda r: None)
        config = Nmea2000OutputConfig.model_validate(
            {"type": "nmea2000", "interface": "virtual", "channel": channel, **cfg})
        out = Nmea2000Output(config, ctx)
        out.check()
        peer = Peer(channel)
        await out.open()
        rig = Rig(clock, out, peer)
        made.append(rig)
        return rig

    yield _make
    for rig in made:
        await rig.out.close()
        rig.peer.close()
