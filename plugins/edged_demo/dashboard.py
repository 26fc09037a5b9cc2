"""The demo's live dashboard, drawn from a snapshot: pure, so that it can be tested.

`render(snapshot, now)` builds a rich renderable from what `feed.LatestFeed.snapshot()`
returns (the newest estimate payload of each estimator, as Zenoh and MCAP carry it,
and the newest 1 Hz health snapshot) and the time `now` (UTC seconds) it is drawn
at. It reads nothing else, not the clock, not the runtime: the same snapshot and time
draw the same screen.

What is not known is shown as "—", never as the last number seen: an estimate that
is flagged `stale`, or older than `STALE_AFTER_S` at `now` (its estimator stopped
publishing), shows none of its values; nor does a health snapshot that old
(`view`). The parts are drawn by `tables` (sources, estimators' health, outputs) and
`panels` (STW, manoeuvring, draft); this module lays them out for the terminal's width.
"""

from __future__ import annotations

import time
from io import StringIO
from typing import Any, Mapping

from rich.console import Console, Group, RenderableType
from rich.table import Table
from rich.text import Text

from . import units as u
from .panels import draft_panel, manoeuvre_panel, stw_panel
from .tables import estimators, outputs, sources
from .units import DASH
from .view import STALE_AFTER_S, fresh_health, get, status

__all__ = ["STALE_AFTER_S", "render", "render_text"]


def header(snapshot: Mapping[str, Any], now: float) -> Text:
    health, word = fresh_health(snapshot, now)
    vessel = snapshot.get("vessel_id") or get(snapshot.get("health"), "vessel_id") or DASH
    when = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(now))
    text = Text.assemble(("edged demo", "bold"), f"  vessel {vessel}  {when}  overall: ")
    text.append_text(status(health is not None and word == "ok", word))
    started = u.num(snapshot.get("started"))
    if started is not None:
        text.append(f"  running {u.seconds(max(0.0, now - started))}")
    return text


def _panels(parts: list[RenderableType], width: int) -> RenderableType:
    """The panels side by side, as many to a row as `width` columns hold (about 50
    each), so that the dashboard fits a screen's height on a wide terminal."""
    per_row = max(1, min(len(parts), width // 50))
    rows: list[RenderableType] = []
    for i in range(0, len(parts), per_row):
        grid = Table.grid(expand=True, padding=(0, 1))
        for _ in range(per_row):
            grid.add_column(ratio=1)
        chunk = parts[i:i + per_row]
        grid.add_row(*chunk, *([""] * (per_row - len(chunk))))
        rows.append(grid)
    return Group(*rows)


def render(snapshot: Mapping[str, Any], now: float, width: int = 160) -> RenderableType:
    """The whole dashboard for `snapshot` (see `feed.LatestFeed.snapshot`, optionally
    with `vessel_id` and `started`) drawn at UTC time `now`, laid out for a terminal
    `width` columns wide."""
    return Group(
        header(snapshot, now),
        sources(snapshot, now),
        _panels([stw_panel(snapshot, now), manoeuvre_panel(snapshot, now), draft_panel(snapshot, now)], width),
        estimators(snapshot, now),
        outputs(snapshot, now),
    )


def render_text(snapshot: Mapping[str, Any], now: float, width: int = 160) -> str:
    """The dashboard as plain text (tests, logs): no colours, `width` columns."""
    console = Console(file=StringIO(), width=width, record=True, color_system=None, force_terminal=False)
    console.print(render(snapshot, now, width))
    return console.export_text()
