"""NMEA 0183 log files for `edged replay`: reading (detection is `logs.sniff`'s).

Reads in chunks through the same Framer as the live input, then stamps each line with
the log's time (ReplayStamper). Counters as the live input (`lines`, `accepted`,
`rejected.<reason>`, `comments`) plus `rejected.no_time`, `rejected.bad_time` (a TAG
or epoch time outside the plausible window of edged.timecheck) and `assumed_date`.
"""

from __future__ import annotations

from typing import Any, BinaryIO, Callable, Iterable, Iterator

from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord
from edged.timecheck import TimeWindow, limits_of

from . import PROTOCOL
from .framer import Framer
from .lines import BAD_TIME, NO_TIME, Framed
from .reporting import ProblemReporter
from .timeofday import ReplayStamper, parse_date_option

CHUNK = 1 << 16
#: NMEA 2000 in checksummed NMEA 0183 sentences (SeaSmart `$PCDIN`, Shipmodul
#: `$MXPGN`), alone or among other sentences: framed and timed here like any sentence,
#: then handed to the CAN decoder (protocol "can", the gateway format in the meta,
#: `edged_can.formats.pcdin` / `.mxpgn`), so they decode as the same data on a bus would.
_TO_CAN = {b"$PCDIN,": "pcdin", b"$MXPGN,": "mxpgn"}


def meta_of(fr: Framed) -> dict[str, Any] | None:
    """What the record's bytes do not say: the TAG block, kept whole."""
    return {"tag": fr.tag} if fr.tag is not None else None


class _Records:
    """Lines placed in time -> records, counted once per chunk as framing's `lines`
    is (so the counters add up between chunks, and no count is made per line)."""

    def __init__(self, source: str, health: ComponentHealth, path: str | None) -> None:
        self.source = source
        self.health = health
        self.reporter = ProblemReporter(health)
        self.where = f" in {path}" if path else ""

    def __call__(self, placed: list[tuple[Framed, float]], n_assumed: int) -> list[RawRecord]:
        health, source = self.health, self.source
        if n_assumed:
            health.count("assumed_date", n_assumed)
            self.reporter.report(f"no date{self.where} (no RMC/ZDA): times of day placed on 1970-01-01; give --date")
        health.count("accepted", len(placed))
        out = []
        for fr, t in placed:
            fmt = _TO_CAN.get(fr.sentence[:7])
            if fmt is not None:
                health.count(f"n2k_sentences.{fmt}")
                out.append(RawRecord("can", source, t, fr.sentence, {"format": fmt}))
            else:
                out.append(RawRecord(PROTOCOL, source, t, fr.sentence, meta_of(fr)))
        return out


def _stamper(options: ReplayOptions, health: ComponentHealth) -> tuple[ReplayStamper, Callable[[float], bool]]:
    """The stamper of the log's lines, and the window a TAG/epoch time must be in.

    A TAG/epoch time outside the log's plausible window costs its line only: it is
    judged before the stamper sees it, so it never sets the time of later lines. An
    RMC/ZDA date is judged by the stamper in a window of its own, a day wider (a date
    a day off is possible, a talker's at midnight; one decades off is not)."""
    try:
        day = parse_date_option(options.date)
    except ValueError:
        health.error(f"replay date {options.date!r} is not YYYY-MM-DD: ignored")
        day = None
    limits = limits_of(options)
    stamper = ReplayStamper(day, accept=TimeWindow(limits, ahead=limits.ahead + 86400.0).accept)
    return stamper, TimeWindow(limits).accept


def _place(
    framed: Iterable[Framed], framer: Framer, stamper: ReplayStamper, accept: Callable[[float], bool]
) -> tuple[list[tuple[Framed, float]], int]:
    """A chunk's lines placed in time (those the stamper let go of), and how many of
    them are on an assumed date; the others rejected through `framer`."""
    placed: list[tuple[Framed, float]] = []
    n_assumed = 0
    push = stamper.push
    for fr in framed:
        if fr.t_log is not None and not accept(fr.t_log):
            framer.reject(BAD_TIME)
            continue
        ready = push(fr)
        if ready is None:
            framer.reject(NO_TIME)
        elif ready.__class__ is str:
            framer.reject(ready)  # type: ignore[arg-type]
        elif ready:
            placed += ready
            if stamper.assumed_date:
                n_assumed += len(ready)
    return placed, n_assumed


def read_log(
    stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
) -> Iterator[RawRecord]:
    cfg = options.config
    framer = Framer(health, getattr(cfg, "checksum", "require") if cfg is not None else "require")
    stamper, accept = _stamper(options, health)
    records = _Records(source, health, options.path)
    while True:
        chunk = stream.read(CHUNK)
        placed, n_assumed = _place(framer.feed(chunk) if chunk else framer.flush(), framer, stamper, accept)
        if placed:
            yield from records(placed, n_assumed)
        if not chunk:
            break
    placed = stamper.finish()
    if placed:
        yield from records(placed, len(placed) if stamper.assumed_date else 0)
