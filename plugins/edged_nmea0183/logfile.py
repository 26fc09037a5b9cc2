"""NMEA 0183 log files for `edged replay`: reading (detection is `logs.sniff`'s).

Reads in chunks through the same Framer as the live input, then stamps each line with
the log's time (ReplayStamper). Counters as the live input (`lines`, `accepted`,
`rejected.<reason>`, `comments`) plus `rejected.no_time`, `rejected.bad_time` (a TAG
or epoch time outside the plausible window of edged.timecheck) and `assumed_date`.
"""

from __future__ import annotations

from typing import Any, BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord
from edged.timecheck import TimeWindow, limits_of

from .framer import Framer
from .lines import BAD_TIME, NO_TIME, Framed
from .logs import PROTOCOL
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


def read_log(
    stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
) -> Iterator[RawRecord]:
    cfg = options.config
    framer = Framer(health, getattr(cfg, "checksum", "require") if cfg is not None else "require")
    try:
        day = parse_date_option(options.date)
    except ValueError:
        health.error(f"replay date {options.date!r} is not YYYY-MM-DD: ignored")
        day = None
    # A TAG/epoch time outside the log's plausible window costs its line only: it is
    # judged before the stamper sees it, so it never sets the time of later lines. An
    # RMC/ZDA date is judged by the stamper in a window of its own, a day wider (a date
    # a day off is possible, a talker's at midnight; one decades off is not).
    limits = limits_of(options)
    accept = TimeWindow(limits).accept
    stamper = ReplayStamper(day, accept=TimeWindow(limits, ahead=limits.ahead + 86400.0).accept)
    reporter = ProblemReporter(health)
    where = f" in {options.path}" if options.path else ""

    def records(placed: list[tuple[Framed, float]], n_assumed: int) -> list[RawRecord]:
        """Lines placed in time -> records, counted once per chunk as framing's `lines`
        is (so the counters add up between chunks, and no call is made per line)."""
        if n_assumed:
            health.count("assumed_date", n_assumed)
            reporter.report(f"no date{where} (no RMC/ZDA): times of day placed on 1970-01-01; give --date")
        health.count("accepted", len(placed))
        out = []
        for fr, t in placed:
            fmt = _TO_CAN.get(fr.sentence[:7])
            if fmt is not None:
                health.count(f"n2k_sentences.{fmt}")
                out.append(RawRecord("can", source, t, fr.sentence, {"format": fmt}))
            else:
                out.append(RawRecord(PROTOCOL, source, t, fr.sentence, None if fr.tag is None else {"tag": fr.tag}))
        return out

    push = stamper.push
    while True:
        chunk = stream.read(CHUNK)
        placed: list[tuple[Framed, float]] = []
        n_assumed = 0
        for fr in framer.feed(chunk) if chunk else framer.flush():
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
        if placed:
            yield from records(placed, n_assumed)
        if not chunk:
            break
    placed = stamper.finish()
    if placed:
        yield from records(placed, len(placed) if stamper.assumed_date else 0)
