"""Time for log lines that carry only a UTC time of day (DESIGN §3).

Extraction is a string split of the few sentences that carry time (GGA, RMC, ZDA,
GLL), not a second parse: it runs on every line of a replay, ahead of the decoder.
"""

from __future__ import annotations

import datetime as _dt
from typing import Callable

from .lines import BAD_TIME, Framed

DAY = 86400.0
HALF_DAY = 43200.0
_EPOCH_ORDINAL = _dt.date(1970, 1, 1).toordinal()


def parse_tod(s: str) -> float | None:
    """`hhmmss[.sss]` -> seconds since midnight; None when empty or impossible."""
    if len(s) < 6 or not s[:6].isdigit():
        return None
    if len(s) > 6 and (s[6] != "." or not (len(s) == 7 or s[7:].isdigit())):
        return None  # float() would also take "123519e3", "123519.5_5", "123519 "
    try:
        v = float(s)
    except ValueError:
        return None
    # Floor division and subtraction rather than divmod(): the same exact results (the
    # differences are representable), a third cheaper, and this runs twice per GGA.
    h = v // 10000.0
    rest = v - h * 10000.0
    m = rest // 100.0
    sec = rest - m * 100.0
    if h >= 24.0 or m >= 60.0 or sec >= 61.0:  # 60.x: a leap second
        return None
    return h * 3600.0 + m * 60.0 + sec


def epoch_day(year: int, month: int, day: int) -> int | None:
    """Days since 1970-01-01 of a calendar date; None when the date does not exist."""
    try:
        return _dt.date(year, month, day).toordinal() - _EPOCH_ORDINAL
    except ValueError:
        return None


def parse_date_option(s: str | None) -> int | None:
    """`YYYY-MM-DD` (the replay `--date`) -> epoch day; ValueError when malformed."""
    if not s:
        return None
    return _dt.date.fromisoformat(s).toordinal() - _EPOCH_ORDINAL


def nearest_time(t: float, tod: float) -> float:
    """The instant with time of day `tod` closest to `t` (for a sentence's own time)."""
    base = t - t % DAY + tod
    if base - t > HALF_DAY:
        return base - DAY
    if t - base > HALF_DAY:
        return base + DAY
    return base


def _year(y: int) -> int | None:
    """Full year; two-digit years (RMC, and some ZDA talkers) read as 1980..2079."""
    if y < 100:
        return (2000 if y < 80 else 1900) + y
    return y if y >= 1980 else None  # before GPS: a receiver's placeholder


def _ddmmyy(s: str) -> int | None:
    if len(s) < 6 or not s[:6].isdigit():
        return None
    year = _year(int(s[4:6]))
    return epoch_day(year, int(s[2:4]), int(s[0:2])) if year is not None else None


def _gga(f: list[str]) -> tuple[float | None, int | None]:
    return parse_tod(f[1]), None


def _gll(f: list[str]) -> tuple[float | None, int | None]:
    return (parse_tod(f[5]), None) if len(f) > 5 else (None, None)


def _rmc(f: list[str]) -> tuple[float | None, int | None]:
    tod = parse_tod(f[1])
    # A date without a time (e.g. `$GPRMC,,V,...,230394`) is a receiver's placeholder.
    return tod, (_ddmmyy(f[9]) if tod is not None and len(f) > 9 else None)


def _zda(f: list[str]) -> tuple[float | None, int | None]:
    tod = parse_tod(f[1])
    if tod is None or len(f) < 5:
        return tod, None
    if not (f[2].isdigit() and f[3].isdigit() and f[4].isdigit()):  # int() takes "+1", " 1", "1_0"
        return tod, None
    year = _year(int(f[4]))
    return tod, (epoch_day(year, int(f[3]), int(f[2])) if year is not None else None)


_EXTRACTORS: dict[bytes, Callable[[list[str]], tuple[float | None, int | None]]] = {
    b"GGA": _gga,
    b"GLL": _gll,
    b"RMC": _rmc,
    b"ZDA": _zda,
}


def sentence_time(sentence: bytes) -> tuple[float | None, int | None]:
    """(UTC time of day, epoch day) a sentence states; (None, None) when none."""
    stype = sentence[3:6]
    if stype not in _EXTRACTORS:  # first: most sentences carry no time
        return None, None
    if sentence[6:7] != b"," or sentence[0] != 0x24:
        return None, None
    if stype == b"GGA":  # the most frequent: its time is field 1, no split needed
        end = sentence.find(b",", 7)
        return parse_tod(sentence[7:end].decode("ascii")), None
    ex = _EXTRACTORS.get(stype)
    if ex is None:
        return None, None
    f = sentence.decode("ascii").partition("*")[0].split(",")
    if len(f) < 2:
        return None, None
    return ex(f)


class ReplayStamper:
    """Gives each replayed line its UTC time, DESIGN §3.

    - A line with a TAG time or epoch prefix has that time; it also sets the clock for
      later untagged lines.
    - Otherwise a line takes the latest time of day seen (GGA/RMC/ZDA/GLL), on the date
      of the latest RMC/ZDA, else the `--date` given; when the time of day steps back
      by more than 12 h the date rolls over (midnight).
    - Before any time is known a line cannot be placed: `push` returns None for it.
    - An RMC/ZDA whose date and time are refused by `accept` (the log's plausible-time
      window) is rejected (`push` returns BAD_TIME) and changes nothing.
    - Lines with a time of day but no date yet wait (up to `max_pending` lines) for the
      first date in the log, so a GGA before the first RMC is not lost. Lines of a log
      that states no date are placed on 1970-01-01 (`assumed_date` is True while so;
      `--date` avoids it).
    """

    __slots__ = ("_day", "_tod", "_offset", "_pending", "_max_pending", "_accept", "assumed_date")

    def __init__(
        self, day: int | None = None, max_pending: int = 20_000, accept: Callable[[float], bool] | None = None
    ) -> None:
        self._day = day  # epoch day; None while unknown
        self._tod: float | None = None
        self._offset = 0  # midnights passed while the day is unknown
        self._pending: list[tuple[Framed, int, float]] = []
        self._max_pending = max_pending
        #: judges the time a sentence's own date gives (edged.timecheck.TimeWindow.accept)
        self._accept = accept
        self.assumed_date = False

    def push(self, fr: Framed) -> list[tuple[Framed, float]] | str | None:
        """Lines now placed in time, in order; None when `fr` has no time (skip it);
        BAD_TIME when the date `fr` states, with its time of day, is refused by the
        `accept` given (`fr` is rejected, the stamper's date unchanged)."""
        if fr.t_log is not None:
            t = fr.t_log
            tod = t % DAY
            self._observe(tod, int(t // DAY))
            ready = self._resolve_pending()
            ready.append((fr, t))
            return ready
        tod, day = sentence_time(fr.sentence)
        if tod is not None:
            if day is not None and self._accept is not None and not self._accept(day * DAY + tod):
                return BAD_TIME  # a date that cannot be true must not date the lines after it
            self._observe(tod, day)
        elif self._tod is None:
            return None
        if self._day is None:
            self._pending.append((fr, self._offset, self._tod))  # type: ignore[arg-type]
            if len(self._pending) >= self._max_pending:
                return self.finish()
            return []
        t = self._day * DAY + self._tod  # type: ignore[operator]
        if not self._pending:
            return [(fr, t)]
        ready = self._resolve_pending()
        ready.append((fr, t))
        return ready

    def finish(self) -> list[tuple[Framed, float]]:
        """End of log (or too many waiting): place waiting lines on an assumed date."""
        if self._pending and self._day is None:
            self.assumed_date = True
            self._day = self._offset  # pending offsets count from day 0
        return self._resolve_pending()

    def _observe(self, tod: float, day: int | None) -> None:
        prev = self._tod
        self._tod = tod
        if prev is not None and tod < prev - HALF_DAY:
            if self._day is None:
                self._offset += 1
            else:
                self._day += 1
        if day is not None:
            self._day = day  # the sentence's own date wins over the rollover guess
            self.assumed_date = False

    def _resolve_pending(self) -> list[tuple[Framed, float]]:
        if not self._pending:
            return []
        base = self._day - self._offset  # type: ignore[operator]
        out = [(fr, (base + off) * DAY + tod) for fr, off, tod in self._pending]
        self._pending = []
        self._offset = 0
        return out
