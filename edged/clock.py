"""Clocks: the only place edged reads time.

Live: anchored once to UTC at start, then advanced by the monotonic clock, so that an
NTP step on the gateway never makes data time jump. Replay: driven by the data, the
clock is whatever time the latest record carried. Everything that needs "now" is handed
one of these; nothing else calls `time.time()`.
"""

from __future__ import annotations

import time
from typing import Callable, Protocol

_INF = float("inf")


class Clock(Protocol):
    def now(self) -> float:
        """UTC seconds (UNIX epoch)."""
        ...

    def monotonic(self) -> float:
        """Seconds on a clock that never steps, for rates and timeouts."""
        ...


class LiveClock:
    """UTC anchored once, advanced monotonically (immune to NTP steps)."""

    def __init__(
        self,
        wall: Callable[[], float] = time.time,
        mono: Callable[[], float] = time.monotonic,
    ) -> None:
        self._mono = mono
        self._anchor_utc = wall()
        self._anchor_mono = mono()

    def now(self) -> float:
        return self._anchor_utc + (self._mono() - self._anchor_mono)

    def monotonic(self) -> float:
        return self._mono()


class ReplayClock:
    """Time is the data's time: set by the replay driver as records pass.

    Never goes backwards: a record older than the clock leaves it where it is, so that
    rates computed from it stay sane across the small reorderings real logs contain.
    Never goes to a time that is not finite either (NaN and +inf leave it where it is):
    the readers reject implausible times (edged.timecheck), this is the last guard.
    """

    def __init__(self, start: float = 0.0) -> None:
        self._t = start

    def advance_to(self, t: float) -> None:
        if self._t < t < _INF:  # NaN fails both comparisons
            self._t = t

    def now(self) -> float:
        return self._t

    def monotonic(self) -> float:
        return self._t


class ManualClock(ReplayClock):
    """A clock tests move by hand."""

    def set(self, t: float) -> None:
        self._t = t

    def step(self, dt: float) -> None:
        self._t += dt
