"""Yacht Devices RAW (YDWG-02, YDEN-02, YDNR): `hh:mm:ss.mmm R|T <id> xx xx …`, one CAN frame a line.

`R` is a frame the gateway received from the bus, `T` one it sent onto it: both are
bus traffic and decoded alike (`T` lines are also counted `frames.tx`, by the decoder). The id is the
29-bit identifier in 8 hex digits, the data 0-8 bytes in hex.

Time is a UTC time of day only (the gateway's clock, set from the bus). The date:
- `--date` (`ReplayOptions.date`, YYYY-MM-DD) when given: it wins;
- else the log's own: the first valid PGN 126992 System Time (bytes 2-3 days since
  1970, bytes 4-7 seconds since midnight × 1e-4, little-endian) or 129029 GNSS
  Position (days and seconds in its first two fast-packet frames). The line's day is
  the one that puts its time of day nearest that UTC time (a gateway stamping local
  time, or a System Time sent just before midnight, still gets the right day).
  Lines before it are held, at most HOLD of them (the oldest beyond that are
  rejected `no_date`), and released with that date. A log with no date at all and no
  `--date`: every line is `rejected.no_date`, with one error naming `--date`; never
  placed on 1970-01-01.
- Midnight: a time of day more than 12 h before the previous line's rolls the date
  over, as for NMEA 0183 logs (a step back of at most BACK_TOLERANCE across midnight,
  23:59:59.9 after 00:00:00.1, is the same day's jitter, not a second roll-over).
- A step back of more than BACK_TOLERANCE (and at most 12 h) is rejected
  `time_backwards`, the line only; CONFIRM such lines in a row that agree with each
  other are taken as the log's new time (a gateway whose clock was set back).
Ours: the `nmea2000` package reads this format (`CAN_FRAME_ASCII`) but has no date,
no per-reason counts, and does not keep the line for the recording.
"""

from __future__ import annotations

import re
from collections import deque
from typing import Any, BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.records import RawRecord
from edged.timecheck import BAD_TIME

from . import DAY_MS, Bad, Frame, n2k_utc_ms
from .textlog import Judges, judges, matched_lines, replay_day

NAME = "ydwg_raw"
_LINE = re.compile(rb"\s*(\d{2}):(\d{2}):(\d{2})\.(\d{3}) ([RT]) ([0-9A-Fa-f]{1,8})((?: [0-9A-Fa-f]{2})*) ?\s*")
_SNIFF = re.compile(rb"\d{2}:\d{2}:\d{2}\.\d{3} [RT] [0-9A-Fa-f]{8}(?: [0-9A-Fa-f]{2}){0,8} ?\s*")
#: Lines held while the date is not known yet.
HOLD = 10_000
HALF_DAY_MS = DAY_MS // 2
#: A step back in time this small is a gateway's jitter, not a time going backwards.
BACK_TOLERANCE_MS = 1000
#: Consecutive lines agreeing on an earlier time that make it the log's time.
CONFIRM = 10
_PGN_SYSTEM_TIME = 126992
_PGN_GNSS = 129029


def sniff(head: bytes) -> bool:
    lines = [ln for ln in head.splitlines()[:20] if ln.strip()]
    good = [ln for ln in lines[:10] if _SNIFF.fullmatch(ln)]
    return bool(good) and len(good) >= max(1, len(lines[:10]) - 1)


class DayClock:
    """Times of day -> milliseconds since midnight of the first line's day, with the
    midnight roll-over and the backwards rule above. `place` returns None for a line
    going back in time (to be rejected)."""

    __slots__ = ("newest", "_run", "_run_last")

    def __init__(self) -> None:
        self.newest: int | None = None
        self._run = 0
        self._run_last = 0

    def place(self, tod_ms: int) -> int | None:
        newest = self.newest
        if newest is None:
            self.newest = tod_ms
            return tod_ms
        rel = newest - newest % DAY_MS + tod_ms
        step = rel - newest
        if step < -HALF_DAY_MS:
            rel += DAY_MS  # midnight
        elif step > DAY_MS - BACK_TOLERANCE_MS:
            rel -= DAY_MS  # a hair before midnight, after it
        if rel < newest - BACK_TOLERANCE_MS:
            if self._run and self._run_last - BACK_TOLERANCE_MS <= rel <= self._run_last + 60_000:
                self._run += 1
            else:
                self._run = 1
            self._run_last = rel
            if self._run < CONFIRM:
                return None
            self.newest = rel  # the log's clock was set back: follow it
        elif rel > newest:
            self.newest = rel
        self._run = 0
        return rel


class DateFinder:
    """The UTC time (ms since 1970) the frames of a log state: PGN 126992 (one frame)
    or 129029 (days and seconds in its first two fast-packet frames, per source)."""

    __slots__ = ("_first", "_earliest", "_latest")

    def __init__(self, earliest: float, latest: float) -> None:
        self._first: dict[int, tuple[int, int, int]] = {}  # src -> (sequence, days, low 3 bytes of seconds)
        self._earliest = earliest
        self._latest = latest

    def push(self, can_id: int, data: bytes) -> int | None:
        pgn = (can_id >> 8) & 0x3FFFF  # both PGNs are PDU2: PS is part of the PGN
        if pgn == _PGN_SYSTEM_TIME:
            if len(data) < 8:
                return None
            return self._utc(data[2] | data[3] << 8, int.from_bytes(data[4:8], "little"))
        if pgn != _PGN_GNSS or not data:
            return None
        src = can_id & 0xFF
        seq, index = data[0] >> 5, data[0] & 0x1F
        if index == 0:
            if len(data) >= 8:
                self._first[src] = (seq, data[3] | data[4] << 8, data[5] | data[6] << 8 | data[7] << 16)
            return None
        first = self._first.pop(src, None)
        if index != 1 or first is None or first[0] != seq or len(data) < 2:
            return None
        return self._utc(first[1], first[2] | data[1] << 24)

    def _utc(self, days: int, secs_e4: int) -> int | None:
        return n2k_utc_ms(days, secs_e4, self._earliest, self._latest)


def day_of(utc_ms: int, tod_ms: int) -> int:
    """The day on which time of day `tod_ms` is nearest the UTC instant `utc_ms`."""
    return (utc_ms - tod_ms + HALF_DAY_MS) // DAY_MS


class _Dating:
    """The date of a log's lines: `--date`, else the first one its frames state, the
    lines before it held (at most HOLD, the oldest beyond that `rejected.no_date`)."""

    def __init__(self, source: str, health: ComponentHealth, options: Any, j: Judges) -> None:
        self.source = source
        self.judges = j
        self.no_date = (
            f"no date for its time of day: no PGN 126992/129029 with a date in the log (within {HOLD} lines); "
            "give it with `edged replay --date YYYY-MM-DD`"
        )
        #: The epoch day of the first line's day; None until known.
        self.base = replay_day(options, health)
        self.finder = DateFinder(j.limits.earliest, j.limits.latest) if self.base is None else None
        self.pending: deque[tuple[int, bytes, int]] = deque()
        self.meta = {"format": NAME}

    def found(self, rel: int, m: re.Match[bytes]) -> bool:
        """Whether the line's frame states the date (then `base` is known)."""
        assert self.finder is not None
        try:
            utc = self.finder.push(int(m.group(6), 16), bytes.fromhex(m.group(7).decode()))
        except ValueError:
            utc = None
        if utc is None:
            return False
        self.base = day_of(utc, rel % DAY_MS) - rel // DAY_MS
        return True

    def hold(self, rel: int, s: bytes, lineno: int) -> None:
        self.pending.append((rel, s, lineno))
        if len(self.pending) > HOLD:
            self.pending.popleft()
            self.judges.reject("no_date", self.no_date)

    def release(self) -> Iterator[RawRecord]:
        """The lines held, now that the date is known."""
        while self.pending:
            r = self.out(*self.pending.popleft())
            if r is not None:
                yield r

    def out(self, rel: int, s: bytes, lineno: int) -> RawRecord | None:
        t = (self.base * DAY_MS + rel) / 1000.0  # type: ignore[operator]
        if not self.judges.accept(t):
            self.judges.reject(BAD_TIME, f"line {lineno}: time {s[:12]!r} cannot be true")
            return None
        return RawRecord("can", self.source, t, s, self.meta)

    def finish(self) -> None:
        """The end of the log: the lines still held never got a date."""
        for _ in range(len(self.pending)):
            self.judges.reject("no_date", self.no_date)
        self.pending.clear()


def read(stream: BinaryIO, source: str, health: ComponentHealth, options: Any = None) -> Iterator[RawRecord]:
    j = judges(source, health, options)
    reject = j.reject
    dating = _Dating(source, health, options, j)
    clock = DayClock()
    for lineno, s, m in matched_lines(stream, reject, _LINE, "not a Yacht Devices RAW line"):
        hh, mm, ss, ms = (int(x) for x in m.group(1, 2, 3, 4))
        if hh > 23 or mm > 59 or ss > 60:
            reject(BAD_TIME, f"line {lineno}: no such time of day {s[:12]!r}")
            continue
        rel = clock.place(((hh * 60 + mm) * 60 + ss) * 1000 + ms)
        if rel is None:
            reject("time_backwards", f"line {lineno}: time {s[:12]!r} goes back more than {BACK_TOLERANCE_MS} ms")
            continue
        if dating.base is None:
            if not dating.found(rel, m):
                dating.hold(rel, s, lineno)
                continue
            yield from dating.release()
        r = dating.out(rel, s, lineno)
        if r is not None:
            yield r
    dating.finish()


def frame(data: bytes) -> list[Frame]:
    m = _LINE.fullmatch(data)
    if m is None:
        raise Bad("bad_line", f"not a Yacht Devices RAW line: {data[:60]!r}")
    ident = m.group(6)
    can_id = int(ident, 16)
    if len(ident) != 8 or can_id >> 29:
        raise Bad("bad_id", f"identifier {ident.decode()} is not a 29-bit NMEA 2000 identifier in 8 hex digits")
    payload = bytes.fromhex(m.group(7).decode())
    if len(payload) > 8:
        raise Bad("bad_length", f"frame {ident.decode()} with {len(payload)} data bytes (a CAN frame has at most 8)")
    return [Frame(can_id, payload, m.group(5) == b"T")]
