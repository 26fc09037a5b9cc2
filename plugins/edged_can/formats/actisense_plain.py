"""canboat / Actisense "plain" text: `time,prio,pgn,src,dst,len,hex,hex,…`, one per line.

What canboat's `analyzer` reads and `actisense-serial` writes, and what Signal K's
`.data` samples hold:
- one CAN frame per line (`len` ≤ 8; a fast-packet PGN's frames one by one), or
- a whole message per line (`len` > 8: the gateway or logger already reassembled the
  fast-packet, canboat's PLAIN_FAST), or both in one file (PLAIN_MIX_FAST: the decoder
  keeps one copy and counts the other, `n2k.N2kDecoder`).
Times are ISO 8601 (`2016-02-28T19:57:02.364Z`) or canboat's older
`2021-08-06-11:45:30.505`; without a zone they are taken as UTC. PGNs above 0x3FFFF are
the gateway's own (Actisense NGT commands and status): counted `gateway_messages`, not
decoded. Ours: the `nmea2000` package reads this format too, but gives neither per-
reason counts nor the line's own bytes for the recording.
"""

from __future__ import annotations

import re
from datetime import datetime, timezone
from typing import Any, BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.records import RawRecord
from edged.timecheck import BAD_TIME

from . import Bad, Frame, Message, can_id
from .textlog import judges, matched_lines

NAME = "actisense_plain"
_LINE = re.compile(
    rb"\s*(\d{4}-\d{2}-\d{2})[T-](\d{2}):(\d{2}):(\d{2}(?:\.\d+)?)(Z|[+-]\d{2}:?\d{2})?"
    rb",([0-7]),(\d{1,8}),(\d{1,3}),(\d{1,3}),(\d{1,3})((?:,[0-9A-Fa-f]{1,2})*),?\s*"
)
MAX_PGN = 0x3FFFF
MAX_LENGTH = 223  # the longest fast-packet message


def sniff(head: bytes) -> bool:
    lines = [ln for ln in head.splitlines()[:20] if ln.strip() and not ln.lstrip().startswith(b"#")]
    good = [ln for ln in lines[:10] if _LINE.fullmatch(ln)]
    return bool(good) and len(good) >= max(1, len(lines[:10]) - 1)


_DAYS: dict[bytes, float] = {}


def _day(date: bytes) -> float:
    """UNIX time of a date's midnight UTC (cached: a log has few dates, many lines)."""
    base = _DAYS.get(date)
    if base is None:
        base = datetime.strptime(date.decode(), "%Y-%m-%d").replace(tzinfo=timezone.utc).timestamp()
        if len(_DAYS) < 4096:
            _DAYS[date] = base
    return base


def _time(m: re.Match[bytes]) -> float:
    date, hh, mm, ss, zone = m.group(1, 2, 3, 4, 5)
    if int(hh) > 23 or int(mm) > 59 or float(ss) >= 61.0:
        raise ValueError("no such time of day")
    base = _day(date)
    t = base + int(hh) * 3600 + int(mm) * 60 + float(ss)
    if zone and zone != b"Z":
        sign = -1 if zone[:1] == b"+" else 1
        z = zone[1:].replace(b":", b"")
        t += sign * (int(z[:2]) * 3600 + int(z[2:]) * 60)
    return t


def read(stream: BinaryIO, source: str, health: ComponentHealth, options: Any = None) -> Iterator[RawRecord]:
    j = judges(source, health, options)
    meta = {"format": NAME}
    for lineno, s, m in matched_lines(stream, j.reject, _LINE, "not an Actisense/canboat plain line"):
        try:
            t = _time(m)
        except ValueError:
            j.reject(BAD_TIME, f"line {lineno}: no such date or time {s[:30]!r}")
            continue
        if not j.accept(t):
            j.reject(BAD_TIME, f"line {lineno}: time {s[:30]!r} cannot be true")
            continue
        yield RawRecord("can", source, t, s, meta)


def frame(data: bytes) -> list[Frame | Message]:
    m = _LINE.fullmatch(data)
    if m is None:
        raise Bad("bad_line", f"not an Actisense/canboat plain line: {data[:60]!r}")
    prio, pgn, src, dst, n = (int(x) for x in m.group(6, 7, 8, 9, 10))
    hexes = m.group(11).split(b",")[1:]
    if len(hexes) != n:
        raise Bad("bad_length", f"PGN {pgn}: length {n} but {len(hexes)} data bytes")
    if src > 255 or dst > 255:
        raise Bad("bad_address", f"PGN {pgn}: source {src} / destination {dst} beyond 255")
    payload = bytes(int(h, 16) for h in hexes)
    if pgn > MAX_PGN:
        raise Bad("gateway_message", f"PGN {pgn} is the gateway's own")
    if n > MAX_LENGTH:
        raise Bad("bad_length", f"PGN {pgn}: {n} bytes, more than a fast-packet holds ({MAX_LENGTH})")
    if n > 8:
        return [Message(prio, pgn, src, dst, payload)]
    return [Frame(can_id(prio, pgn, src, dst), payload)]
