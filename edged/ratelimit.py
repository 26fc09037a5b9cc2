"""Per-key rate limit on data time, so that replay publishes exactly what live did.

Measurement topics are optional extras for on-board displays (DESIGN §6): a 100 Hz
draft mark need not cross a satellite link at 100 Hz, and a bridge output sends each
sentence or PGN at its own rate (`edged.bridgeoutput`). The limit is judged on the
records' own time `t`, never the wall clock, so the same input gives the same
published subset at any replay speed.
"""

from __future__ import annotations

from pydantic import BaseModel, Field, field_validator

from .records import KINDS

__all__ = ["DataTimeRateLimiter", "MeasurementRates"]

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


#: The highest rate a measurement limit may name: above any sensor's, i.e. no limit.
MAX_HZ = 1_000_000.0


class MeasurementRates(BaseModel):
    """Mixin of an output's configuration that serves measurements (the Zenoh topics,
    the live Foxglove channels): the highest rate of each, by kind."""

    #: Highest rate per measurement topic or channel (Hz of data time); 0 switches a
    #: kind off, 1000000 lets every measurement through.
    meas_default_hz: float = Field(10.0, ge=0, le=MAX_HZ)
    #: Per measurement kind, overriding `meas_default_hz`.
    meas_max_hz: dict[str, float] = Field(default_factory=dict)

    @field_validator("meas_max_hz")
    @classmethod
    def _kinds(cls, v: dict[str, float]) -> dict[str, float]:
        for kind, hz in v.items():
            if kind not in KINDS:
                raise ValueError(f"unknown measurement kind {kind!r} (known: {', '.join(KINDS)})")
            if not 0 <= hz <= MAX_HZ:
                raise ValueError(f"{kind}: {hz} is not a rate between 0 and {MAX_HZ:.0f} Hz")
        return v

    def hz(self, kind: str) -> float:
        """The rate limit of a measurement kind (Hz of data time)."""
        return float(self.meas_max_hz.get(kind, self.meas_default_hz))
