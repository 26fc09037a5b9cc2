"""A worker's calls to its core, in data time: its inputs in order become steps, with
the ticks of its grid between them (`CallPlan`).

Time for cores is data time. Records carry it; health snapshots (1 Hz, published
through the router like any record) are the beacons that move it on when no input
arrives. Before a record of time t is stepped, every tick k/rate <= t of the worker's
grid is fired: publication at `publish_rate` and `stale` marking come from those
ticks (`edged.publication`), so the same log gives the same ticks at any replay
speed. With a `reorder_window`, inputs are held until the newest is that much later,
and released in time order; an input older than what was stepped is late (counted,
dropped).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections import deque
from typing import Any

from .health import ComponentHealth
from .records import HealthRecord

__all__ = ["CallPlan", "MAX_CATCHUP_TICKS"]

#: Ticks fired at once when data time jumps (a gap in a log): beyond, the grid skips
#: to the latest tick (counted `ticks_skipped`) instead of firing hours of them.
MAX_CATCHUP_TICKS = 1000

Call = tuple[str, Any]


class CallPlan:
    """Turns one worker's ordered inputs into calls: `("step", record)` and
    `("tick", t)`, each with its cause (the number of the input it came with)."""

    def __init__(self, health: ComponentHealth, reorder_window: float, publish_rate: float, ticking: bool) -> None:
        self.health = health
        self.window = reorder_window
        #: (t, n, record): inputs held by the reorder window, earliest first.
        self.reorder: list[tuple[float, int, Any]] = []
        self._n = itertools.count()
        self._newest = -math.inf  # newest input time admitted
        self._stepped = -math.inf  # newest input time stepped (older inputs are late)
        self._ticking = ticking
        #: The next tick is k / rate: an integer, so that the grid never drifts and
        #: every run (live, a replay from any file) fires the very same tick times.
        self._rate = publish_rate if publish_rate > 0 else 1.0
        self._next_k: int | None = None
        #: The data time from which a tick is due (-inf: no time seen yet; inf: none).
        self._tick_at = -math.inf if ticking else math.inf

    def admit_ready(self, pending: deque[tuple[int, int, int, Any]], bound: int, limit: int,
                    calls: list[Call], causes: list[int]) -> bool:
        """Admit the pending inputs numbered up to `bound`, until `limit` calls; True
        when some within the bound are left for the next batch."""
        pop = pending.popleft
        admit = self.admit
        while pending and pending[0][0] <= bound and len(calls) < limit:
            seq, _, _, rec = pop()
            admit(seq, rec, calls, causes)
        return bool(pending) and pending[0][0] <= bound

    def admit(self, seq: int, rec: Any, calls: list[Call], causes: list[int]) -> None:
        """One input in sequence order: ticks up to its time, then its step(s)."""
        t = rec.t
        if rec.__class__ is HealthRecord:
            # A beacon: data time moves on. With a reorder window, only to its horizon:
            # what is still held there is stepped first, in time order, as a later
            # input would have released it.
            if self.window > 0.0:
                t -= self.window
                while self.reorder and self.reorder[0][0] <= t:
                    self._step(heapq.heappop(self.reorder)[2], seq, calls, causes)
            self._tick_to(t, seq, calls, causes)
            return
        if self.window > 0.0:
            if t < self._newest - self.window or t < self._stepped:
                self.health.count("late")
                return
            heapq.heappush(self.reorder, (t, next(self._n), rec))
            if t > self._newest:
                self._newest = t
            horizon = self._newest - self.window
            while self.reorder and self.reorder[0][0] <= horizon:
                self._step(heapq.heappop(self.reorder)[2], seq, calls, causes)
            return
        if t < self._stepped:
            self.health.count("late")
            return
        self._step(rec, seq, calls, causes)

    def _step(self, rec: Any, seq: int, calls: list[Call], causes: list[int]) -> None:
        t = rec.t
        if t >= self._tick_at:
            self._tick_to(t, seq, calls, causes)
        if t > self._stepped:
            self._stepped = t
        calls.append(("step", rec))
        causes.append(seq)

    def _tick_to(self, t: float, seq: int, calls: list[Call], causes: list[int]) -> None:
        if not t >= self._tick_at or not math.isfinite(t):  # nothing due (no ticks, no time)
            return
        rate = self._rate
        k = self._next_k
        if k is None:  # the grid is absolute: k / rate in data time
            k = self._next_k = math.floor(t * rate) + 1
            self._tick_at = k / rate
            return
        last = math.floor(t * rate)  # the latest tick at or before t
        if last / rate > t:  # floor of a product that rounded up
            last -= 1
        n = last - k + 1
        if n > MAX_CATCHUP_TICKS:
            self.health.count("ticks_skipped", n - 1)
            k = last
            n = 1
        for i in range(k, k + n):
            calls.append(("tick", i / rate))
            causes.append(seq)
        k = self._next_k = k + n
        self._tick_at = k / rate

    def release(self, seq: int, calls: list[Call], causes: list[int]) -> None:
        """Step everything the reorder window holds (the worker finishes)."""
        while self.reorder:
            self._step(heapq.heappop(self.reorder)[2], seq, calls, causes)

    def drop_held(self) -> int:
        """Forget what the reorder window holds (held for a core that failed: counted,
        not replayed); how many."""
        n = len(self.reorder)
        self.reorder.clear()
        return n
