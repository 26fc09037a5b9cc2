"""A worker's inputs in one order that depends only on the data, and its watermark.

Replay equals live, chained estimators included (DESIGN §2). A worker's inputs are
measurements from the router and estimates of the workers it consumes (the draft
worker takes `est/stw`). Live, those arrive in an order that depends on scheduling;
`InputOrder` puts them back into one order:

- the router numbers every record it publishes (`Router.seq`); an estimate carries
  the number of the record it was made from (its *cause*);
- a worker orders its inputs by (number, producer, production order): a measurement
  first, then what its upstream workers made from it, in the configuration's
  topological order of those workers;
- it steps its core only up to its *bound*: the highest number below which nothing
  can still arrive, i.e. everything the router has published and everything its
  upstream workers have finished (their *watermark*). A worker with nothing to do is
  finished up to its own bound, so an idle upstream never holds a downstream back.
"""

from __future__ import annotations

import collections
import itertools
from typing import Any, Iterable

from .router import BoundedQueue, Router

__all__ = ["InputOrder", "OrderedEstimates"]

#: Producer rank of router records (measurements, health): before every estimate.
_MEASUREMENT_RANK = -1
#: The queue item that only wakes a worker (an upstream worker finished a batch).
_WAKE = (0, None)

Item = tuple[int, int, int, Any]


class InputOrder:
    """One worker's ordering: its inputs waiting their turn, its place among the other
    workers, and how far it is done."""

    def __init__(self, router: Router, queue: BoundedQueue) -> None:
        self.router = router
        self.queue = queue
        #: (seq, producer rank, n, record), kept sorted: the inputs in stepping order.
        self.pending: collections.deque[Item] = collections.deque()
        self._n = itertools.count()
        #: Workers whose estimates this one consumes, and those consuming its own.
        self.upstream: list[InputOrder] = []
        self.downstream: list[InputOrder] = []
        #: Topological position: orders the estimates of several upstream workers.
        self.rank = 0
        self._ranks: dict[str, int] = {}
        self.done = 0  # watermark: everything caused by numbers <= this is published
        self.busy = False  # batches on their way to the core
        self.finished = False  # nothing more will be published (finished or gave up)

    def link(self, upstream: list["InputOrder"], names: list[str], rank: int) -> None:
        """Whose estimates this worker consumes (their instance `names`), and its
        place in the topological order."""
        self.upstream = upstream
        self.rank = rank
        for u in upstream:
            u.downstream.append(self)
        self._ranks = {f"est/{n}": u.rank for u, n in zip(upstream, names)}

    def watermark(self) -> int:
        """Every estimate this worker will make from records numbered <= this is
        already published."""
        if self.finished:
            return self.router.seq
        if self.busy or self.pending or len(self.queue):
            return self.done
        return self.bound()

    def bound(self) -> int:
        """Numbers up to which this worker has all its inputs."""
        b = self.router.seq
        for up in self.upstream:
            w = up.watermark()
            if w < b:
                b = w
        return b

    def ready_bound(self) -> int:
        """The bound, held back by what is still queued (a batch cut to keep the
        backlog bounded): nothing at or above the oldest number there is complete."""
        bound = self.bound()
        if len(self.queue):
            oldest = min((seq for seq, rec in self.queue if rec is not None), default=bound + 1)
            if oldest <= bound:
                bound = oldest - 1
        return bound

    def done_after(self, bound: int, more: bool) -> int:
        """The watermark once the calls taken up to `bound` are applied (`more`: some
        inputs within the bound wait for the next batch)."""
        if not more:
            return bound
        # Everything numbered below the next pending record is done.
        return max(self.done, min(bound, self.pending[0][0] - 1))

    def wake(self) -> None:
        self.queue.put(_WAKE)

    def wake_downstream(self) -> None:
        for d in self.downstream:
            d.wake()

    def take(self, items: Iterable[tuple[int, Any]]) -> None:
        """Queue the inputs in (number, producer rank) order. They nearly always come
        in that order already (measurements straight from the router): appended, with
        no heap of the whole backlog (at a replay's rate the backlog is tens of
        thousands, and a heap's pop cost a few µs each). An upstream estimate
        carries the number of the record it was made from, so it arrives after
        records numbered later: then one merge of the two sorted runs (Python's sort
        is linear on runs)."""
        ranks = self._ranks
        n = self._n
        new = [(seq, ranks.get(rec.route_key, _MEASUREMENT_RANK) if ranks else _MEASUREMENT_RANK, next(n), rec)
               for seq, rec in items if rec is not None]
        if not new:
            return
        pending = self.pending
        if (not pending or pending[-1] < new[0]) and all(a < b for a, b in zip(new, itertools.islice(new, 1, None))):
            pending.extend(new)
        else:
            pending.extend(new)
            self.pending = collections.deque(sorted(pending))


class OrderedEstimates:
    """An output's estimates in the order of the records they were made from, each
    released once every worker it takes estimates from is done up to it.

    Workers in processes of their own run apart, seconds of data apart in a fast
    replay; an output that puts several estimators' values side by side (a bridge
    output: the heading beside the STW) would then combine what live never did.
    Ordered, it sees them as live did, whatever the workers' pace. `get_batch` stands
    in for the queue's: what is released, or [] when the queue was woken.
    """

    def __init__(self, router: Router, queue: BoundedQueue) -> None:
        self.queue = queue
        self.order = InputOrder(router, queue)

    def link(self, upstream: list[InputOrder], names: list[str]) -> None:
        """The workers whose estimates the output takes (their orders and names)."""
        self.order.link(upstream, names, rank=len(upstream))

    def _release(self, bound: int, max_items: int) -> list[Any]:
        pending = self.order.pending
        out: list[Any] = []
        while pending and pending[0][0] <= bound and len(out) < max_items:
            out.append(pending.popleft()[3])
        return out

    async def get_batch(self, max_items: int = 1024) -> list[Any]:
        order = self.order
        while True:
            out = self._release(order.bound(), max_items)
            if out:
                return out
            items = await self.queue.get_batch(max_items)
            if not items:
                return []  # woken: the output host has something else to see to
            order.take(items)

    def drain_nowait(self) -> list[Any]:
        """Everything queued and held, in order (the stop: nothing more will come)."""
        self.order.take(self.queue.drain_nowait())
        out = [item[3] for item in self.order.pending]
        self.order.pending.clear()
        return out

    def __len__(self) -> int:
        return len(self.queue) + len(self.order.pending)
