"""The plausible-time window of a replayed log (DESIGN §3, §8).

A log's own time is data like any other and can be wrong: a TAG block `c:20000000000`
(year 2603), a candump `(inf)`, a recording's `"t": Infinity`. Such a time must not
reach the replay clock (which never goes back: one absurd time would stop every later
tick and pace), nor the recorder (MCAP times are unsigned 64-bit nanoseconds). The
readers reject it by reason `rejected.bad_time` and go on with the next line.

A time is plausible when it is finite, not before `earliest` (default 1980-01-01, the
GPS epoch's year: nothing that logs NMEA is older), not after `latest` (default
2100-01-01, an absolute ceiling well inside MCAP's range) and not more than `ahead`
(default one day) after the newest plausible time seen so far in the same log. The
window is per log: each reader makes its own `TimeWindow`, and some adapt it to
their format:
- candump logs are judged from 0 on rather than 1980 (`candump -t z` counts from
  zero): negative times are still refused, and times before 1980 do not anchor the
  one-day rule (which counts only from times after the limits' `earliest`);
- an MCAP recording, from 0 on (it may hold untimed records stamped 0.0) and without
  the one-day rule (edged's own merge of files that may be days apart);
- the date of an NMEA RMC/ZDA sentence in a window of its own, a day wider.

The limits are configurable: a `TimeLimits` given to the `Replayer`
(`time_limits=`) reaches every reader through its `ReplayOptions` (attribute
`time_limits`, read with `limits_of`); without one the defaults below hold.

A log that truly jumps ahead by more than `ahead` (a logger off for a week that
appends to the same file) is followed after `CONFIRM` consecutive lines that agree on
the new time (see `TimeWindow`): those lines before it are rejected, not the rest of
the log.

What the window cannot know: when the *first* time of a log is absurd but finite and
before `latest` (say 2099), it becomes the newest good time and the log's true times,
older, still pass. Such a log replays with a clock stuck at that time; the earliest
and latest bounds keep it at least representable.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: 1980-01-01T00:00:00Z
EARLIEST = 315532800.0
#: 2100-01-01T00:00:00Z
LATEST = 4102444800.0
#: A log's time may run this far ahead of the newest good time seen in it.
AHEAD = 86400.0
INF = float("inf")
#: Consecutive agreeing times beyond the window that make it move to them.
CONFIRM = 10
#: Reason of a rejection (counted as `rejected.bad_time`).
BAD_TIME = "bad_time"


@dataclass(frozen=True)
class TimeLimits:
    earliest: float = EARLIEST
    latest: float = LATEST
    ahead: float = AHEAD

    def __post_init__(self) -> None:
        for name in ("earliest", "latest", "ahead"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or v != v:
                raise ValueError(f"time limit {name} must be a number, not {v!r}")
        if not -INF < self.earliest < self.latest < INF:
            raise ValueError("time limits: earliest and latest must be finite, earliest < latest")
        if self.ahead < 0:  # +inf: no one-day rule
            raise ValueError("time limits: ahead must be >= 0 (inf: no limit)")


DEFAULT_LIMITS = TimeLimits()


def limits_of(options: Any) -> TimeLimits:
    """The limits a replay passed to a reader in its options (the defaults if none)."""
    limits = getattr(options, "time_limits", None)
    return limits if isinstance(limits, TimeLimits) else DEFAULT_LIMITS


class TimeWindow:
    """Judges the times of one log in order; `accept(t)` is True for a plausible time
    (and moves the window's top along), False for one to reject.

    A log may truly jump ahead by more than `ahead` (a logger off for a week that
    appends to the same file): `confirm` consecutive rejected times, each before
    `latest` and within `ahead` of the one before, are taken as the log's new time
    (the last of them is accepted, the window moves to it). A jump thus costs
    `confirm - 1` lines; a stray line, or a few not agreeing with each other, only
    themselves. `confirm=0` never re-anchors."""

    __slots__ = ("earliest", "latest", "ahead", "newest", "confirm", "_anchor", "_top", "_run", "_run_last")

    def __init__(
        self,
        limits: TimeLimits = DEFAULT_LIMITS,
        *,
        earliest: float | None = None,
        ahead: float | None = None,
        confirm: int = CONFIRM,
    ) -> None:
        self.earliest = limits.earliest if earliest is None else earliest
        self.latest = limits.latest
        self.ahead = limits.ahead if ahead is None else ahead
        self.confirm = confirm
        #: Only a time from `limits.earliest` on is a date that the one-day rule can
        #: count from; smaller ones (a reader's `earliest=0.0` for relative logs) are not.
        self._anchor = limits.earliest
        self.newest: float | None = None
        self._top = limits.latest
        self._run = 0  # consecutive rejected times that agree with each other
        self._run_last = 0.0

    def accept(self, t: float) -> bool:
        # NaN fails both comparisons; ±inf fails one: no separate finiteness test.
        if self.earliest <= t <= self._top:
            self._run = 0
            newest = self.newest
            if newest is None or t > newest:
                self._move(t)
            return True
        if self._top < t <= self.latest and self.confirm > 0:
            if self._run and abs(t - self._run_last) <= self.ahead:
                self._run += 1
            else:
                self._run = 1
            self._run_last = t
            if self._run >= self.confirm:
                self._run = 0
                self._move(t)
                return True
        return False

    def _move(self, t: float) -> None:
        self.newest = t
        if t >= self._anchor:
            top = t + self.ahead
            self._top = top if top < self.latest else self.latest

    def __contains__(self, t: float) -> bool:
        """Whether `t` would be accepted now, without moving the window."""
        return self.earliest <= t <= self._top
