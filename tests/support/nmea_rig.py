"""A live NMEA 0183 input with a context that keeps what it publishes (tests only)."""

from __future__ import annotations

import asyncio
from typing import Any

from edged.clock import ManualClock
from edged.plugin import PluginContext
from edged.records import Measurement, RawRecord
from edged_nmea0183.config import Nmea0183Config
from edged_nmea0183.plugin import Nmea0183Input

NOW = 1_700_000_000.0
TIMEOUT = 10.0


class Sink:
    """`publish` of the context: keeps records, wakes waiters."""

    def __init__(self) -> None:
        self.items: list[Any] = []
        self._cond: asyncio.Condition | None = None

    def __call__(self, rec: Any) -> None:
        self.items.append(rec)
        if self._cond is not None:
            asyncio.get_running_loop().create_task(self._wake())

    async def _wake(self) -> None:
        async with self._cond:  # type: ignore[union-attr]
            self._cond.notify_all()  # type: ignore[union-attr]

    async def wait_raw(self, n: int) -> list[RawRecord]:
        if self._cond is None:
            self._cond = asyncio.Condition()
        async with self._cond:
            await asyncio.wait_for(self._cond.wait_for(lambda: len(self.raw) >= n), TIMEOUT)
        return self.raw

    @property
    def raw(self) -> list[RawRecord]:
        return [r for r in self.items if isinstance(r, RawRecord)]

    @property
    def measurements(self) -> list[Measurement]:
        return [r for r in self.items if isinstance(r, Measurement)]


def make(health, sleep=None, **cfg: Any) -> tuple[Nmea0183Input, Sink]:
    config = Nmea0183Config(type="nmea0183", **cfg)
    sink = Sink()
    ctx = PluginContext(
        name="gnss1",
        clock=ManualClock(NOW),
        health=health,
        publish=sink,
        decoder=Nmea0183Input.make_decoder("gnss1", config, health),
    )
    kw = {"sleep": sleep} if sleep is not None else {}
    return Nmea0183Input(config, ctx, **kw), sink
