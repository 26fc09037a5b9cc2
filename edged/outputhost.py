"""One output behind its queue (`OutputHost`): batches taken from the router's queue
and written through the output's placement (`edged.outputproc`: in the event loop or
in a process of its own), the same way for both; a failed write ends its run, and the
runtime's supervisor starts it again with backoff.
"""

from __future__ import annotations

import asyncio
from collections import deque
from typing import Any

from .childmain import CallFailed
from .childproc import forget
from .clock import Clock
from .health import ComponentHealth
from .outputproc import place_output
from .plugin import OutputPlugin
from .ordering import OrderedEstimates
from .router import BoundedQueue, Router

__all__ = ["OutputHost"]


class OutputHost:
    """Runs one output behind its queue. `plugin` is the output's placement
    (`edged.outputproc`: in the loop, or in a process of its own with `worker =
    "process"`), through which every call of the plugin's contract goes."""

    def __init__(self, name: str, plugin: OutputPlugin, router: Router, health: ComponentHealth,
                 clock: Clock | None = None, *, ordered: bool = False) -> None:
        self.name = name
        self.clock = clock or plugin.ctx.clock
        self.plugin = place_output(plugin, name, health, self.clock)
        self.health = health
        self.opened = False
        self._progress: asyncio.Future[None] | None = None
        #: Waiting for room for its next batch (see `run`).
        self.blocked = False
        self.sub = router.subscribe(
            f"output:{name}",
            plugin.keys,
            exclude=plugin.exclude_keys,
            maxsize=plugin.config.queue_size,
            health=health,
            preferred_only=False,
            reorder_window=None,
            sequenced=ordered,
        )
        #: Where batches are taken from: the queue, or (`ordered`: a replay of an output
        #: that combines estimators, `OutputPlugin.ordered`) the estimates put in the
        #: order of the records they were made from (`link` names the workers).
        self.source: BoundedQueue | OrderedEstimates = (
            OrderedEstimates(router, self.sub.queue) if ordered else self.sub.queue)

    def link(self, workers: list[Any]) -> None:
        """(ordered) The worker hosts whose estimates it takes: each batch holds only
        what every one of them is done with."""
        if isinstance(self.source, OrderedEstimates):
            self.source.link([w.order for w in workers], [w.name for w in workers])

    @property
    def up(self) -> bool:
        """Open in its place: in a process, once that has started and opened the
        plugin (`opened` is set before: batches go behind the start)."""
        return self.opened and self.plugin.up

    async def run(self) -> None:
        """Up to the placement's `depth` batches on their way (in a process: the next is
        taken, and pickled, while the child writes the last; in the loop each is
        written when it is taken). The host takes what is queued at the same moments
        in either placement (with the clock as it then reads), so each batch is
        written as in the loop; while it waits for room, `blocked` tells a replay to
        wait. A write that failed (the process died) wakes the host at once, not at
        the next record: its run ends and the supervisor starts it again."""
        place = self.plugin
        await place.open()
        self.opened = True
        queue = self.sub.queue
        source = self.source
        clock = self.clock
        count = self.health.count
        inflight: deque[tuple[asyncio.Future[Any], int]] = deque()

        def done(fut: asyncio.Future[Any]) -> None:
            if fut.cancelled() or fut.exception() is not None:
                queue.wake()

        while True:
            while inflight and inflight[0][0].done():
                self._settle(inflight)
            if len(inflight) >= place.depth:
                self.blocked = True
                try:
                    await asyncio.wait([inflight[0][0]])
                finally:
                    self.blocked = False
                self._progressed()
                continue
            batch = await source.get_batch(place.batch)
            if not batch:
                continue  # woken: a write failed
            self._progressed()
            try:
                fut = place.send(batch, clock.now(), clock.monotonic())
            except Exception:  # (in the loop) the plugin raised: the batch is lost
                count("dropped.write_failed", len(batch))
                raise
            count("written", len(batch))
            if fut is not None:
                fut.add_done_callback(done)
                inflight.append((fut, len(batch)))

    def _settle(self, inflight: deque[tuple[asyncio.Future[Any], int]]) -> None:
        """The oldest write is done: forget it, or raise what it failed with (every
        batch still on its way is then lost with it, and counted)."""
        fut, _ = inflight[0]
        exc = fut.exception()
        if exc is None:
            inflight.popleft()
            self._progressed()
            return
        lost = sum(n for _, n in inflight)
        if isinstance(exc, CallFailed):  # the plugin raised on this batch; the process goes on
            self.health.count("dropped.write_failed", inflight[0][1])
            for f, n in list(inflight)[1:]:  # each one behind it is written or refused in its turn
                f.add_done_callback(lambda f, n=n: self._refused(f, n))
        for f, _ in inflight:  # their failures are this one's
            forget(f)
        inflight.clear()
        raise self.plugin.failed(exc, lost)

    def _refused(self, fut: asyncio.Future[Any], n: int) -> None:
        """A write sent behind one that failed, refused by the plugin too (behind an
        open that failed): its records counted lost."""
        if not fut.cancelled() and isinstance(fut.exception(), CallFailed):
            self.health.count("dropped.write_failed", n)

    def progress(self) -> "asyncio.Future[None]":
        """Done when the output next takes a batch from its queue (replay waits on it
        rather than polling the loop, which would hold the GIL a process output's
        threads need)."""
        if self._progress is None or self._progress.done():
            self._progress = asyncio.get_running_loop().create_future()
        return self._progress

    def _progressed(self) -> None:
        p = self._progress
        if p is not None and not p.done():
            p.set_result(None)

    async def close(self) -> None:
        """(also a process that started but failed to open: it goes too)"""
        self.opened = False
        await self.plugin.close()

    def flush(self) -> None:
        if self.opened:
            try:
                self.plugin.flush()
            except Exception as exc:
                self.health.error(f"flush: {type(exc).__name__}: {exc}")

    async def drain_and_close(self) -> None:
        """The stop: what is queued goes to the plugin, which is then closed. An output
        that is not open (failed, or its process dead and waiting for its restart)
        takes nothing: its queue is counted lost, `dropped.not_open`."""
        if not self.opened and await self.plugin.started():
            self.opened = True  # stopped while its process was starting: it takes the queue
        if not self.opened:
            rest = self.source.drain_nowait()
            if rest:
                self.health.count("dropped.not_open", len(rest))
        if self.opened:
            rest = self.source.drain_nowait()
            if rest:
                try:
                    self.plugin.write(rest)
                    self.health.count("written", len(rest))
                except Exception as exc:
                    self.health.count("dropped.final_write", len(rest))
                    self.health.error(f"final write: {type(exc).__name__}: {exc}")
            self.flush()
        await self.close()
