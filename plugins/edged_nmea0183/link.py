"""Keeps a live transport open: watchdog, reconnect with exponential backoff, health.

States (ComponentHealth.set_state): `connecting` -> `connected` -> (`stale` when the
watchdog fires | `disconnected` when the peer goes away) -> `connecting` ...; a regular
file that ends is `finished`. Counters: `bytes`, `connects`, `connect_failures`,
`disconnects`, `watchdog`.
"""

from __future__ import annotations

import asyncio
from typing import Awaitable, Callable

from edged.backoff import Backoff
from edged.health import ComponentHealth

from .transports.base import Transport

Sleep = Callable[[float], Awaitable[None]]


class Link:
    def __init__(
        self,
        transport: Transport,
        health: ComponentHealth,
        *,
        watchdog: float,
        backoff: Backoff,
        sleep: Sleep = asyncio.sleep,
    ) -> None:
        self.transport = transport
        self.health = health
        self.watchdog = watchdog
        self.backoff = backoff
        self._sleep = sleep

    async def run(self, on_data: Callable[[bytes], None], on_reset: Callable[[], None]) -> None:
        """Deliver received bytes to `on_data` until cancelled (or a regular file ends).

        `on_reset` is called after every connection ends, so that a partial line of
        the old connection is not glued to the first bytes of the next.
        """
        h = self.health
        where = self.transport.describe()
        while True:
            h.set_state("connecting", where)
            try:
                await self.transport.open()
            except OSError as exc:
                h.count("connect_failures")
                h.error(f"{where}: cannot open: {exc.strerror or exc}")
                h.set_state("disconnected", "open failed")
                await self._sleep(self.backoff.next_delay())
                continue
            h.count("connects")
            h.set_state("connected", where)
            try:
                ended = await self._pump(on_data)
            except OSError as exc:
                h.error(f"{where}: link broke: {exc}")
                ended = False
            finally:
                await self.transport.close()
                on_reset()
            if ended and self.transport.finite:
                h.set_state("finished", where)
                return
            h.count("disconnects")
            h.set_state("disconnected", where)
            await self._sleep(self.backoff.next_delay())

    async def _pump(self, on_data: Callable[[bytes], None]) -> bool:
        """Read until the stream ends (True) or the watchdog fires (False)."""
        h = self.health
        read = self.transport.read
        finite = self.transport.finite
        while True:
            try:
                # asyncio.timeout, not wait_for: on Python 3.11 wait_for returns the
                # result and swallows a cancellation that arrives as data does, so a
                # busy link could never be stopped.
                async with asyncio.timeout(None if finite else self.watchdog):
                    chunk = await read()
            except TimeoutError:
                h.count("watchdog")
                h.set_state("stale", f"no data for {self.watchdog:g} s")
                return False
            if not chunk:
                return True
            h.count("bytes", len(chunk))
            self.backoff.reset()  # the link works: the next failure starts afresh
            on_data(chunk)
