"""Per-key rate limit on data time, so that replay publishes exactly what live did.

Measurement topics are optional extras for on-board displays (DESIGN §6): a 100 Hz
draft mark need not cross a satellite link at 100 Hz, and a bridge output sends each
sentence or PGN at its own rate (`edged.bridgeoutput`). The limit is judged on the
records' own time `t`, never the wall clock, so the same input gives the same
published subset at any replay speed.
"""

from __future__ import annotations

__all__ = ["DataTimeRateLimiter"]

# Time may step back by this much (seconds) before the limiter assumes a new
# recording started and forgets the past; smaller steps are reordering and dropped.
_RESTART_AFTER = 1.0
# A record up to this fraction of a period before its slot is on time: sensors jitter,
# and UNIX seconds carry only ~0.2 µs of resolution. The average rate still never
# exceeds the limit, because each published record moves its slot one period on.
_EARLY = 0.05


class DataTimeRateLimiter:
    """At most `hz` records per second of data time per key.

    Slots sit on a grid (`next += period`) rather than `t + period`, and a record a
    little early for its slot is taken, so a jittery 10 Hz sensor limited to 10 Hz
    keeps its full rate instead of losing every record that arrives a millisecond early. After a gap the grid restarts at the record's time:
    silence earns no burst.
    """

    __slots__ = ("_next",)

    def __init__(self) -> None:
        self._next: dict[str, float] = {}

    def allow(self, key: str, t: float, hz: float) -> bool:
        if hz <= 0.0:
            return False
        period = 1.0 / hz
        nxt = self._next.get(key)
        if nxt is None or t < nxt - period - _RESTART_AFTER:
            self._next[key] = t + period
            return True
        if t < nxt - _EARLY * period:
            return False
        self._next[key] = t + period if t >= nxt + period else nxt + period
        return True
