"""Keeps a live transport open: the watchdog of its reads on the core's reconnect loop.

States and counters are those of every edged link (`edged.link`): `connecting` ->
`connected` -> (`stale` when the watchdog fires: no bytes, or bytes but no line
accepted, for `watchdog` seconds) -> `disconnected` (also when the peer
goes away or the open fails) -> `connecting` ...; a regular file that ends is
`finished`. Counters: `connects`, `connect_failures`, `disconnects`, `watchdog`, and
`bytes` of this input.
"""

from __future__ import annotations

import asyncio
from typing import Callable

from edged.backoff import Backoff
from edged.health import ComponentHealth
from edged.link import Link, LinkLost, LinkStale, Sleep

from .transports.base import Transport

__all__ = ["TransportLink", "Sleep"]


class TransportLink:
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
        self.link: Link[Transport] = Link(health, backoff, where=transport.describe(), sleep=sleep)

    async def run(self, on_data: Callable[[bytes], None], on_reset: Callable[[], None]) -> None:
        """Deliver received bytes to `on_data` until cancelled (or a regular file ends).

        `on_reset` is called after every connection ends, so that a partial line of
        the old connection is not glued to the first bytes of the next.
        """
        transport = self.transport

        async def opener() -> Transport:
            await transport.open()
            return transport

        async def session(t: Transport) -> None:
            await self._pump(on_data)

        async def close(t: Transport) -> None:
            try:
                await t.close()
            finally:
                on_reset()

        await self.link.run(opener, session, close)

    async def _pump(self, on_data: Callable[[bytes], None]) -> None:
        """Read until the stream ends: return for a file, LinkLost/LinkStale otherwise."""
        h = self.health
        read = self.transport.read
        finite = self.transport.finite
        stable = self.link.stable
        counters = h.counters
        clock = asyncio.get_running_loop().time
        accepted = counters.get("accepted", 0)
        since = clock()  # when a line was last accepted (or the session began)
        while True:
            try:
                # asyncio.timeout, not wait_for: on Python 3.11 wait_for returns the
                # result and swallows a cancellation that arrives as data does, so a
                # busy link could never be stopped.
                async with asyncio.timeout(None if finite else self.watchdog):
                    chunk = await read()
            except TimeoutError:
                raise LinkStale(f"no data for {self.watchdog:g} s") from None
            if not chunk:
                if finite:
                    return
                raise LinkLost("closed by the peer")
            h.count("bytes", len(chunk))
            on_data(chunk)
            if counters.get("accepted", 0) != accepted:
                accepted, since = counters.get("accepted", 0), clock()
                stable()  # the link works: the next failure starts afresh
            elif not finite and clock() - since > self.watchdog:
                # Bytes, but no line worth having (an endless line, garbage, the wrong
                # baud rate): as good as silence (issue 32: 5,815 too_long rejections
                # while the input said `connected`, ok).
                raise LinkStale(f"no line accepted for {self.watchdog:g} s while bytes arrive "
                                f"(see the rejected.* counters)")
