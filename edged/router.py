"""The router: fan-out of records to workers and outputs, never blocking the inputs.

Each subscriber has its own bounded queue. `publish()` is synchronous and O(number
of matching subscribers): a full queue drops the record for that subscriber only and
counts it (DESIGN §2: overflow is counted, never silent, never blocking).

Source priority with failover: when two sources give the same kind (heading from a
gyro's HDT and from PGN 127250), the highest-priority source that is fresh (heard from
within `timeout` seconds of data time) is the one subscribers with `preferred_only`
see; a lower one takes over when the first falls silent, and gives back as soon as the
first speaks again. Outputs (recording) still see every source.
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Iterable, Iterator

from .health import ComponentHealth

log = logging.getLogger("edged.router")


class BoundedQueue:
    """A single-consumer bounded FIFO for the event loop; `put` never waits."""

    __slots__ = ("maxsize", "_items", "_waiter", "_woken")

    def __init__(self, maxsize: int) -> None:
        if maxsize < 1:
            raise ValueError("maxsize must be >= 1")
        self.maxsize = maxsize
        self._items: deque[Any] = deque()
        self._waiter: asyncio.Future[None] | None = None
        self._woken = False

    def wake(self) -> None:
        """Make the consumer's `get_batch` return now, empty if nothing is queued
        (something else needs its attention: a process output's failed write)."""
        self._woken = True
        w = self._waiter
        if w is not None:
            self._waiter = None
            if not w.done():
                w.set_result(None)

    def __len__(self) -> int:
        return len(self._items)

    def __iter__(self) -> Iterator[Any]:
        """The queued items, oldest first (without taking them)."""
        return iter(self._items)

    def put(self, item: Any) -> bool:
        items = self._items
        if len(items) >= self.maxsize:
            return False
        items.append(item)
        w = self._waiter
        if w is not None:
            self._waiter = None
            if not w.done():
                w.set_result(None)
        return True

    async def get_batch(self, max_items: int = 1024) -> list[Any]:
        """Wait for at least one item, then take up to `max_items` (or, after
        `wake`, return what there is, maybe nothing)."""
        items = self._items
        while not items:
            if self._woken:
                self._woken = False
                return []
            w = asyncio.get_running_loop().create_future()
            self._waiter = w
            try:
                await w
            finally:
                if self._waiter is w:
                    self._waiter = None
        if len(items) <= max_items:
            # The usual case (the consumer keeps up): take everything in one copy
            # rather than one popleft per record.
            batch = list(items)
            items.clear()
            return batch
        popleft = items.popleft
        return [popleft() for _ in range(max_items)]

    def drain_nowait(self) -> list[Any]:
        out = list(self._items)
        self._items.clear()
        return out


@dataclass(eq=False)
class Subscription:
    """What one worker or output receives.

    keys: route keys (measurement kinds, `est/<name>`, `raw`, `health`); None = all.
    sources: only these sources; None = any.
    preferred_only: see only the priority winner for kinds with a source priority.
    reorder_window: records older than (newest seen − window) are late: counted and
        dropped; None = accept everything in arrival order (outputs).
    """

    name: str
    keys: frozenset[str] | None
    queue: BoundedQueue
    #: Route keys never delivered even when `keys` is None (e.g. `raw` for a publisher).
    exclude: frozenset[str] = frozenset()
    health: ComponentHealth | None = None
    sources: frozenset[str] | None = None
    preferred_only: bool = True
    reorder_window: float | None = None
    #: Queue `(seq, record)` pairs instead of records (estimator workers: the sequence
    #: number is what orders a worker's inputs the same way live and in replay).
    sequenced: bool = False
    newest_t: float = field(default=float("-inf"))
    overflow: int = 0
    late: int = 0

    def wants(self, key: str) -> bool:
        return (self.keys is None or key in self.keys) and key not in self.exclude


#: Sources of one kind a priority keeps before it forgets those silent for ten timeouts.
PRUNE_SOURCES = 64


class SourcePriority:
    """Failover among sources of one kind, judged on data time."""

    def __init__(self, kind: str, sources: Iterable[str], timeout: float) -> None:
        self.kind = kind
        self.rank = {s: i for i, s in enumerate(sources)}
        self.timeout = timeout
        self.last_seen: dict[str, float] = {}
        self.active: str | None = None
        self.switches = 0

    def accept(self, source: str, t: float) -> bool:
        """Note that `source` spoke at `t`; return True if it is the one to use."""
        last = self.last_seen
        prev = last.get(source)
        if prev is None or t > prev:
            last[source] = t
        # Unlisted sources rank after every listed one, in order of first appearance.
        best: str | None = None
        best_rank = 1 << 30
        horizon = t - self.timeout
        n = len(self.rank)
        for s, seen in last.items():
            if seen < horizon:
                continue
            r = self.rank.get(s)
            if r is None:
                r = n
            if r < best_rank:
                best, best_rank = s, r
        if len(last) > PRUNE_SOURCES:
            # Sources long silent (a replay of a thousand one-minute files, each its own
            # source) must not make every record walk all of them.
            old = t - 10.0 * self.timeout
            for s in [s for s, seen in last.items() if seen < old]:
                del last[s]
        if best != self.active:
            if self.active is not None:
                log.info("failover kind=%s from=%s to=%s t=%.3f", self.kind, self.active, best, t)
                self.switches += 1
            self.active = best
        return best == source


class Router:
    def __init__(self, health: ComponentHealth | None = None) -> None:
        self.health = health
        self._subs: list[Subscription] = []
        self._by_key: dict[str, list[Subscription]] = {}
        self.priorities: dict[str, SourcePriority] = {}
        self.published = 0
        self.suppressed = 0
        #: Sequence number of the newest record published: every record gets the next
        #: one, except an estimate, which carries the number of the record it was made
        #: from (`cause`). Every record numbered up to `seq` is in its subscribers'
        #: queues: publish() is synchronous.
        self.seq = 0

    def set_priority(self, kind: str, sources: list[str], timeout: float) -> None:
        self.priorities[kind] = SourcePriority(kind, sources, timeout)

    def subscribe(
        self,
        name: str,
        keys: Iterable[str] | None,
        *,
        exclude: Iterable[str] = (),
        maxsize: int = 10_000,
        health: ComponentHealth | None = None,
        sources: Iterable[str] | None = None,
        preferred_only: bool = True,
        reorder_window: float | None = None,
        sequenced: bool = False,
    ) -> Subscription:
        sub = Subscription(
            name=name,
            keys=None if keys is None else frozenset(keys),
            queue=BoundedQueue(maxsize),
            exclude=frozenset(exclude),
            health=health,
            sources=None if sources is None else frozenset(sources),
            preferred_only=preferred_only,
            reorder_window=reorder_window,
            sequenced=sequenced,
        )
        self._subs.append(sub)
        self._by_key.clear()
        return sub

    def unsubscribe(self, sub: Subscription) -> None:
        if sub in self._subs:
            self._subs.remove(sub)
            self._by_key.clear()

    def _targets(self, key: str) -> list[Subscription]:
        t = self._by_key.get(key)
        if t is None:
            t = [s for s in self._subs if s.wants(key)]
            self._by_key[key] = t
        return t

    def publish(self, rec: Any, cause: int | None = None) -> None:
        """Deliver `rec` to every matching subscriber's queue; never waits.

        `cause`: for an estimate, the sequence number of the record it was made from.
        """
        self.published += 1
        if cause is None:
            self.seq += 1
            cause = self.seq
        key = rec.route_key
        targets = self._by_key.get(key)
        if targets is None:
            targets = self._targets(key)
        if not targets:
            return
        preferred = True
        prio = self.priorities.get(key)
        if prio is not None:
            preferred = prio.accept(rec.source, rec.t)
            if not preferred:
                self.suppressed += 1
        # Estimator workers (sequenced) take a health record as a time beacon only.
        beacon = rec.beacon() if key == "health" else None
        for sub in targets:
            if sub.sources is not None and rec.source not in sub.sources:
                continue
            if not preferred and sub.preferred_only:
                continue
            window = sub.reorder_window
            if window is not None:
                t = rec.t
                if t < sub.newest_t - window:
                    sub.late += 1
                    if sub.health is not None:
                        sub.health.count("late")
                    continue
                if t > sub.newest_t:
                    sub.newest_t = t
            if not sub.queue.put((cause, beacon or rec) if sub.sequenced else rec):
                sub.overflow += 1
                if sub.health is not None:
                    sub.health.count("overflow")


    def subscriptions(self) -> list[Subscription]:
        return list(self._subs)

    def stats(self) -> dict[str, Any]:
        return {
            "published": self.published,
            "suppressed": self.suppressed,
            "active_sources": {k: p.active for k, p in self.priorities.items()},
            "failovers": {k: p.switches for k, p in self.priorities.items()},
            "queues": {
                s.name: {"fill": len(s.queue), "overflow": s.overflow, "late": s.late}
                for s in self._subs
            },
        }
