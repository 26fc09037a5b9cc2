"""What the dashboard's parts share: which values are fresh enough to show, and the
small pieces (ok marks, label/value panels) every part draws with.

An estimate is shown only while it is fresh: not flagged `stale` by its worker and
not older than `STALE_AFTER_S` at the time the frame is drawn (an estimator that
stopped publishing); a health snapshot likewise. Otherwise its values are "—".
"""

from __future__ import annotations

from typing import Any, Mapping

from rich.console import Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from . import units as u
from .units import DASH

#: An estimate or health snapshot older than this (s, at `now`) is not shown. The
#: estimators publish at 1 Hz or faster and flag `stale` themselves after their
#: `stale_after` (5 s by default): this catches the one that stopped publishing.
STALE_AFTER_S = 5.0

Payload = Mapping[str, Any]


# -- what is fresh ----------------------------------------------------------------
def pick(estimates: Mapping[str, Payload], kind: str) -> tuple[str, Payload | None]:
    """The (instance name, payload) of the first estimate of `kind` (the demo runs one
    instance per kind, named after it)."""
    for name, p in estimates.items():
        if p.get("kind") == kind:
            return name, p
    return kind, estimates.get(kind)


def freshness(est: Payload | None, now: float) -> tuple[bool, str]:
    """Whether the estimate's values may be shown, and a word on its state."""
    if est is None:
        return False, "no estimate yet"
    t = u.num(est.get("t"))
    if est.get("stale"):
        return False, f"stale: no input for {u.seconds(est.get('age'))}"
    if t is None or now - t > STALE_AFTER_S:
        return False, f"stale: last estimate {u.seconds(None if t is None else now - t)} ago"
    if est.get("converging"):
        return True, "converging"
    return True, "ok"


def fresh_health(snapshot: Mapping[str, Any], now: float) -> tuple[Mapping[str, Any] | None, str]:
    """The health snapshot when recent enough, else None; and a word on it."""
    h = snapshot.get("health")
    if h is None:
        return None, "waiting for the first health snapshot"
    t = u.num(h.get("t"))
    if t is None or now - t > STALE_AFTER_S:
        return None, f"health snapshot {u.seconds(None if t is None else now - t)} old"
    return h, "ok" if h.get("ok") else "not ok"


def status(ok: bool, word: str) -> Text:
    style = "green" if ok and word == "ok" else ("yellow" if ok else "red")
    return Text(word, style=style)


def tick(ok: Any) -> Text:
    if ok is True:
        return Text("✓ ok", style="green")
    if ok is False:
        return Text("✗ not ok", style="bold red")
    return Text(DASH)


def get(d: Any, *path: str) -> Any:
    """`d[path[0]][path[1]]…`, None where a step is missing or not a mapping."""
    for key in path:
        if not isinstance(d, Mapping):
            return None
        d = d.get(key)
    return d


def rows_panel(title: str, status: Text, rows: list[tuple[str, str | Text]], *, before: RenderableType | None = None,
          after: RenderableType | None = None) -> Panel:
    """A panel of label/value rows, with a table above or below them."""
    grid = Table.grid(padding=(0, 2))
    grid.add_column(style="bold", no_wrap=True)
    grid.add_column()
    for label, value in rows:
        grid.add_row(label, value)
    body = Group(*(part for part in (before, grid, after) if part is not None))
    return Panel(body, title=Text.assemble((title, "bold"), "  ", status), title_align="left")
