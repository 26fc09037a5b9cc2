"""What the readers of the gateway text logs (Actisense plain, Yacht Devices RAW,
iKonvert) do alike: their time window and rejections, `--date`, and the loop over
the file's lines.

Written once here because the three loops were copies of each other (issue 33): a
fix to one (the bound on a line's length, issue 32) had to be made three times.
candump's reader (`edged_can.candump`) does not use it: its lines have a fast path
of their own and their times a window from zero.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import date
from typing import Any, BinaryIO, Callable, Iterator

from edged.health import ComponentHealth
from edged.loglines import numbered_lines
from edged.timecheck import TimeLimits, TimeWindow, limits_of

from . import rejecter

_EPOCH = date(1970, 1, 1).toordinal()


@dataclass(frozen=True)
class Judges:
    """How one log's lines are judged: the replay's time limits, the log's own
    plausible-time window (`accept`), and `reject(reason, message)` (counted
    `rejected.<reason>`, the first message of each reason logged, naming the file)."""

    limits: TimeLimits
    accept: Callable[[float], bool]
    reject: Callable[[str, str], None]


def judges(source: str, health: ComponentHealth, options: Any) -> Judges:
    limits = limits_of(options)
    return Judges(limits, TimeWindow(limits).accept, rejecter(health, f"{source}: "))


def date_day(text: str | None) -> int | None:
    """`YYYY-MM-DD` -> days since 1970-01-01 (ValueError when malformed)."""
    if not text:
        return None
    return date.fromisoformat(text).toordinal() - _EPOCH


def replay_day(options: Any, health: ComponentHealth) -> int | None:
    """The day `edged replay --date` gives (days since 1970), None without one; a
    malformed one is an error in `health` and ignored."""
    text = getattr(options, "date", None)
    try:
        return date_day(text)
    except ValueError:
        health.error(f"replay date {text!r} is not YYYY-MM-DD: ignored")
        return None


def matched_lines(
    stream: BinaryIO,
    reject: Callable[[str, str], None],
    shape: re.Pattern[bytes],
    not_shaped: str,
    comments: bool = True,
) -> Iterator[tuple[int, bytes, re.Match[bytes]]]:
    """(line number, the line stripped, its match) of each line of `stream` that
    `shape` matches whole. Blank lines are skipped, and with `comments` those that
    start with `#`; any other line is `rejected.bad_line` ("line N: <not_shaped>:
    <its start>"), and one too long `rejected.too_long` (`edged.loglines`)."""
    fullmatch = shape.fullmatch
    for lineno, line in numbered_lines(stream, reject):
        s = line.strip()
        if not s or (comments and s.startswith(b"#")):
            continue
        m = fullmatch(s)
        if m is None:
            reject("bad_line", f"line {lineno}: {not_shaped}: {s[:60]!r}")
            continue
        yield lineno, s, m
