"""Digital Yacht iKonvert: `!PDGY,<pgn>,<prio>,<src>,<dst>,<timer>,<base64 payload>`, a whole message a line.

The gateway reassembles fast-packets: each line is a `Message`. Its `$PDGY,…` lines
(`$PDGY,000000,…` status: bus load, errors, devices, uptime; command answers) are the
gateway's own: counted `gateway_status`, not measurements, not records.

What the real logs hold (canboat's `ikonvert.log`), and how it is read:
- the timer is `seconds.milliseconds` with the milliseconds NOT zero-padded:
  `482.37` is 482.037 s (read as a decimal it would run backwards);
- a status sentence may cut into a message without a line end
  (`!PDGY,127250,…,Ai20AAAAAAE=$PDGY,000000,…`): the message ends where the glued
  sentence starts, and each is read on its own;
- a line that does not start with `!PDGY,` / `$PDGY,` (bytes of a lost sentence in
  front: `,o!PDGY,…`) comes from a stream already broken: rejected `bad_line`, whole.

Time: the timer counts seconds since the gateway started, not a date.
- Absolute time comes from the first PGN 126992 System Time (payload bytes 2-3 days
  since 1970, 4-7 seconds since midnight × 1e-4) or 129029 GNSS Position (bytes 1-2,
  3-6) in the log: t = its UTC time + (timer − its timer). Lines before it are held
  (at most HOLD) and released with that time. The first such time holds until the
  gateway restarts (its clock's drift against GNSS time is not followed).
- `--date` wins over the log's date: the first 126992/129029 still gives the time of
  day, on that date; when none comes (within HOLD lines or at all) the timer counts
  from 00:00:00 UTC of that date.
- No time in the log and no `--date`: every line `rejected.no_date`, one error naming
  `--date`; never 1970.
- A timer more than RESTART_TOLERANCE back is a restart of the gateway: counted
  `timer_restarts` (not a rejection: the lines are good), and the lines after it wait
  (at most HOLD) for the next 126992/129029; if none comes, their timer counts from the
  last time before the restart. A smaller step back is the gateway's jitter.
Ours: the `nmea2000` package reads `!PDGY` lines but gives no per-reason counts and no
time; the unpadded milliseconds and the glued sentences need a reader of their own.
"""

from __future__ import annotations

import base64
import binascii
import re
from collections import deque
from typing import Any, BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.records import RawRecord
from edged.timecheck import BAD_TIME

from . import DAY_MS, Bad, Message, n2k_utc_ms
from .textlog import Judges, judges, matched_lines, replay_day
from .ydwg_raw import HOLD, day_of

NAME = "ikonvert"
_MSG = re.compile(rb"!PDGY,(\d{1,7}),([0-7]),(\d{1,3}),(\d{1,3}),(\d{1,10})\.(\d{1,3}),([^,]*)")
_GLUED = re.compile(rb"(?=[!$]PDGY)")
#: What a line must start with: a message or a status sentence (either may be glued).
_SENTENCE = re.compile(rb"[!$]PDGY,.*", re.DOTALL)
_SNIFF_MSG = re.compile(rb"!PDGY,\d{1,7},[0-7],\d{1,3},\d{1,3},\d{1,10}\.\d{1,3},[A-Za-z0-9+/]+={0,2}\s*")
MAX_PGN = 0x3FFFF
MAX_LENGTH = 223  # the longest fast-packet message
#: A timer step back beyond this is a restart of the gateway.
RESTART_TOLERANCE_MS = 1000
_PGN_SYSTEM_TIME = 126992
_PGN_GNSS = 129029


def sniff(head: bytes) -> bool:
    lines = [ln.strip() for ln in head.splitlines()[:40] if ln.strip()][:20]
    msgs = sum(1 for ln in lines if _SNIFF_MSG.fullmatch(ln))
    status = sum(1 for ln in lines if ln.startswith(b"$PDGY,"))
    # A line may be cut (the head's last, a glued status): most, not all, must be whole.
    return msgs >= 1 and msgs + status >= max(1, len(lines) - 2)


def _timer_ms(sec: bytes, ms: bytes) -> int:
    return int(sec) * 1000 + int(ms)  # "482.37" is 482 s and 37 ms


def _utc_ms(pgn: int, b64: bytes, earliest: float, latest: float) -> int | None:
    """The UTC time (ms since 1970) a 126992/129029 message states; None without one."""
    try:
        p = base64.b64decode(b64, validate=True)
    except (binascii.Error, ValueError):
        return None
    if pgn == _PGN_SYSTEM_TIME and len(p) >= 8:
        days, secs = p[2] | p[3] << 8, int.from_bytes(p[4:8], "little")
    elif pgn == _PGN_GNSS and len(p) >= 7:
        days, secs = p[1] | p[2] << 8, int.from_bytes(p[3:7], "little")
    else:
        return None
    return n2k_utc_ms(days, secs, earliest, latest)


class _Timeline:
    """The gateway's timer placed in UTC, run by run (see the module's doc): its
    anchor, the lines held while there is none, and the restarts."""

    def __init__(self, source: str, health: ComponentHealth, options: Any, j: Judges) -> None:
        self.source = source
        self.health = health
        self.judges = j
        self.no_date = (
            f"no date for the gateway's timer: no PGN 126992/129029 with a date in the log (within {HOLD} lines); "
            "give it with `edged replay --date YYYY-MM-DD`"
        )
        self.day = replay_day(options, health)  # --date
        self.meta = {"format": NAME}
        self.anchor: tuple[int, int] | None = None  # (UTC ms, timer ms) of this run of the gateway
        self.last_ms: int | None = None  # the newest time placed
        self.last_timer: int | None = None
        self.pending: deque[tuple[int, bytes, int]] = deque()  # (timer ms, sentence, line) waiting for a time

    def fallback(self) -> tuple[int, int] | None:
        """The anchor when the log states no time: the last time before a restart, else
        00:00 of --date, else none."""
        if self.last_ms is not None:
            return (self.last_ms, 0)
        if self.day is not None:
            return (self.day * DAY_MS, 0)
        return None

    def place(self, timer: int, s: bytes, lineno: int) -> RawRecord | None:
        assert self.anchor is not None
        ms = self.anchor[0] + timer - self.anchor[1]
        t = ms / 1000.0
        if not self.judges.accept(t):
            self.judges.reject(BAD_TIME, f"line {lineno}: time {t!r} cannot be true")
            return None
        if self.last_ms is None or ms > self.last_ms:
            self.last_ms = ms
        return RawRecord("can", self.source, t, s, self.meta)

    def release(self) -> Iterator[RawRecord]:
        if self.anchor is None:
            self.anchor = self.fallback()
        while self.pending:
            item = self.pending.popleft()
            if self.anchor is None:
                self.judges.reject("no_date", self.no_date)
                continue
            r = self.place(*item)
            if r is not None:
                yield r

    def hold(self, timer: int, piece: bytes, lineno: int) -> Iterator[RawRecord]:
        """A message without a time yet waits; beyond HOLD of them, the oldest go."""
        self.pending.append((timer, piece, lineno))
        if len(self.pending) > HOLD:
            if self.fallback() is not None:
                yield from self.release()
            else:
                self.pending.popleft()
                self.judges.reject("no_date", self.no_date)

    def restarted(self, timer: int, lineno: int) -> bool:
        """Whether the timer went back by more than RESTART_TOLERANCE_MS (counted)."""
        last = self.last_timer
        self.last_timer = timer
        if last is None or timer >= last - RESTART_TOLERANCE_MS:
            return False
        self.health.count("timer_restarts")
        self.health.error(
            f"{self.source}: line {lineno}: the gateway's timer went back from {last / 1000:.3f} s to "
            f"{timer / 1000:.3f} s (a restart): times from the next 126992/129029"
        )
        return True

    def utc(self, m: re.Match[bytes]) -> int | None:
        """The UTC time a 126992/129029 message states (on --date's day when given)."""
        pgn = int(m.group(1))
        if pgn not in (_PGN_SYSTEM_TIME, _PGN_GNSS):
            return None
        utc = _utc_ms(pgn, m.group(7), self.judges.limits.earliest, self.judges.limits.latest)
        if utc is None or self.day is None:
            return utc
        # --date wins: the message's time of day, on that date (after a restart: on the
        # day nearest the last time placed)
        ref = self.last_ms if self.last_ms is not None else self.day * DAY_MS + DAY_MS // 2
        return day_of(ref, utc % DAY_MS) * DAY_MS + utc % DAY_MS

    def steady(self, timer: int) -> bool:
        """True, and the timer taken, when the message can be placed at once (the common
        case: an anchor, no restart); else `message` is the way."""
        last = self.last_timer
        if self.anchor is None or last is None or timer < last - RESTART_TOLERANCE_MS:
            return False
        self.last_timer = timer
        return True

    def message(self, m: re.Match[bytes], timer: int, piece: bytes, lineno: int) -> Iterator[RawRecord]:
        """The records a message releases: those held before it, and itself."""
        if self.restarted(timer, lineno):
            yield from self.release()  # the run before the restart, on what it knew
            self.anchor = None
        if self.anchor is None:
            utc = self.utc(m)
            if utc is None:
                yield from self.hold(timer, piece, lineno)
                return
            self.anchor = (utc, timer)
            yield from self.release()
        r = self.place(timer, piece, lineno)
        if r is not None:
            yield r


def read(stream: BinaryIO, source: str, health: ComponentHealth, options: Any = None) -> Iterator[RawRecord]:
    j = judges(source, health, options)
    timeline = _Timeline(source, health, options, j)
    for lineno, s, _ in matched_lines(stream, j.reject, _SENTENCE, "not an iKonvert sentence at the line's start",
                                      comments=False):
        pieces = _GLUED.split(s)[1:] if b"PDGY" in s[5:] else (s,)
        for piece in pieces:
            if piece[:1] == b"$":
                health.count("gateway_status")
                continue
            m = _MSG.fullmatch(piece)
            if m is None:
                j.reject("bad_line", f"line {lineno}: not a whole !PDGY sentence: {piece[:60]!r}")
                continue
            timer = _timer_ms(m.group(5), m.group(6))
            if not timeline.steady(timer):
                yield from timeline.message(m, timer, piece, lineno)
            elif (r := timeline.place(timer, piece, lineno)) is not None:
                yield r
    yield from timeline.release()


def frame(data: bytes) -> list[Message]:
    """A record's message. `read` gives one sentence a record; a live stream's line may
    still hold a glued status sentence (`…=$PDGY,000000,…`): split as `read` does."""
    data = data.strip()
    if data.startswith(b"$PDGY"):  # the gateway's status: nothing on the bus, counted
        raise Bad("gateway_status", "an iKonvert status sentence")
    if not data.startswith(b"!PDGY,"):
        raise Bad("bad_line", f"not an iKonvert sentence at the line's start: {data[:60]!r}")
    if b"PDGY" in data[5:]:
        return [_message(piece) for piece in _GLUED.split(data)[1:] if piece[:1] == b"!"]
    return [_message(data)]


def _message(data: bytes) -> Message:
    m = _MSG.fullmatch(data)
    if m is None:
        raise Bad("bad_line", f"not a whole iKonvert !PDGY sentence: {data[:60]!r}")
    pgn, prio, src, dst = (int(x) for x in m.group(1, 2, 3, 4))
    if pgn > MAX_PGN:
        raise Bad("bad_pgn", f"PGN {pgn} beyond the 18 bits of an NMEA 2000 PGN")
    if src > 255 or dst > 255:
        raise Bad("bad_address", f"PGN {pgn}: source {src} / destination {dst} beyond 255")
    try:
        payload = base64.b64decode(m.group(7), validate=True)
    except (binascii.Error, ValueError):
        raise Bad("bad_base64", f"PGN {pgn}: payload {m.group(7)[:40]!r} is not base64") from None
    if not payload or len(payload) > MAX_LENGTH:
        raise Bad("bad_length", f"PGN {pgn}: {len(payload)} payload bytes (1 to {MAX_LENGTH})")
    return Message(prio, pgn, src, dst, payload)
