"""Drawing the dashboard on a terminal about once a second, with rich's `Live`.

Why a task of the event loop and no refresh thread (`auto_refresh=False`): the
feed's queue belongs to the loop, and a frame drawn between two of the loop's steps
never sees a half-updated snapshot. Log lines (warnings on stderr) would tear the
frame: while it is drawn, the root logger's stderr handler writes through rich, which
prints them above the frame.
"""

from __future__ import annotations

import asyncio
import logging
import sys
from contextlib import contextmanager
from typing import Any, Awaitable, Callable, Iterator, Mapping

from rich.console import Console
from rich.live import Live

from .dashboard import render
from .feed import LatestFeed

log = logging.getLogger("edged.demo")

#: Seconds between frames.
REFRESH_S = 1.0


def _isatty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


@contextmanager
def _live(console: Console) -> Iterator[Live]:
    """A `Live` display; log lines meant for the same terminal go above it."""
    original = sys.stderr
    moved = [
        h for h in logging.getLogger().handlers
        if type(h) is logging.StreamHandler and h.stream is original and _isatty(original) and console.is_terminal
    ]
    with Live(console=console, auto_refresh=False, transient=False, redirect_stdout=False,
              redirect_stderr=bool(moved)) as live:
        for h in moved:
            h.setStream(sys.stderr)  # rich's proxy while the display runs
        try:
            yield live
        finally:
            for h in moved:
                h.setStream(original)


async def run_dashboard(
    feed: LatestFeed,
    console: Console,
    now: Callable[[], float],
    extra: Mapping[str, Any] | None = None,
    *,
    interval: float = REFRESH_S,
    sleep: Callable[[float], Awaitable[None]] = asyncio.sleep,
    refreshes: int | None = None,
) -> None:
    """Redraw from `feed` every `interval` s until cancelled (or after `refreshes`
    frames); the last frame, drawn as it stops, stays on the screen. `extra` joins
    the snapshot (`vessel_id`, `started`)."""
    extra = dict(extra or {})
    failed: list[str] = []

    def frame(live: Live) -> None:
        feed.update()
        try:
            live.update(render({**feed.snapshot(), **extra}, now(), console.width), refresh=True)
        except Exception as exc:  # a payload the dashboard did not expect: said once, the demo goes on
            why = f"{type(exc).__name__}: {exc}"
            if why not in failed:
                failed.append(why)
                log.warning("event=dashboard-failed error=%r", why)

    drawn = 0
    with _live(console) as live:
        try:
            while refreshes is None or drawn < refreshes:
                frame(live)
                drawn += 1
                if refreshes is None or drawn < refreshes:
                    await sleep(interval)
        except asyncio.CancelledError:
            frame(live)  # the state it stopped in stays on the screen
            raise
