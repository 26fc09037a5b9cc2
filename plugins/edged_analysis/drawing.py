"""The picture of `edged plot`: which panels a recording has data for, in which
order, drawn one under the other into a PNG (matplotlib, the `plot` extra, imported
only here and only when a picture is made).

Order, top to bottom: the track, the speeds, per stw instance its panel (with
`truth`: its error and the error's autocorrelation), the motion, rates, drafts, trim
and list, and the marks out. Time panels share their axis, in minutes since the
start of the recording.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

from .panels import acf_panel, error_panel, marks_out_panel, series_panel, stw_panel, track_panel
from .plotdata import PlotData
from .stwdata import ACF_LAGS, error_autocorrelation, stw_error
from .truth import Truth

__all__ = ["Drawer", "drawers", "render"]

#: (panel key, y label) of the time-series panels, top to bottom.
_TIME_PANELS = [
    ("speed", "speed (kn)"),
    ("motion", "velocity (kn)"),
    ("rate", "deg/s, deg"),
    ("draft", "draft (m)"),
    ("trim", "trim, list (m)"),
]

#: (name, axis kind: track | time | lag, what draws it on an axis)
Drawer = tuple[str, str, Callable[[Any], None]]


def _stw_drawers(data: PlotData, truth: Truth | None, max_lag: int, t0: float) -> list[Drawer]:
    """Per stw instance with values: its panel, and against truth its error and the
    error's autocorrelation (when the truth covers it)."""
    drawers: list[Drawer] = []
    for name, s in data.stw.items():
        if not s.has("stw"):
            continue
        drawers.append((f"stw {name}", "time", lambda ax, s=s: stw_panel(ax, s, t0, truth)))
        if truth is None:
            continue
        e = stw_error(s, truth)
        if not e.n:
            continue
        drawers.append((f"error {name}", "time", lambda ax, e=e: error_panel(ax, e, t0)))
        acf = error_autocorrelation(e.err, max_lag)
        if acf.size:
            drawers.append((f"autocorrelation {name}", "lag", lambda ax, e=e, a=acf: acf_panel(ax, e, a)))
    return drawers


def drawers(data: PlotData, truth: Truth | None = None, max_lag: int = ACF_LAGS) -> list[Drawer]:
    """The panels the data has, top to bottom."""
    out: list[Drawer] = []
    if data.tracks:
        out.append(("track", "track", lambda ax: track_panel(ax, data)))
    t0 = data.t0 or 0.0
    for key, ylabel in _TIME_PANELS[:1]:
        if data.panel(key):
            out.append((key, "time", lambda ax, k=key, y=ylabel: series_panel(ax, data, k, y, t0)))
    out += _stw_drawers(data, truth, max_lag, t0)
    for key, ylabel in _TIME_PANELS[1:]:
        if data.panel(key):
            out.append((key, "time", lambda ax, k=key, y=ylabel: series_panel(ax, data, k, y, t0)))
    if data.panel("draft") and data.panel("marks_out"):
        out.append(("marks out", "time", lambda ax: marks_out_panel(ax, data, t0)))
    return out


def render(data: PlotData, out: Path, title: str, truth: Truth | None = None, max_lag: int = ACF_LAGS) -> list[str]:
    """Draw the panels that have data into `out` (PNG); return their names (none: no
    file is written).

    With `truth`: per stw instance whose time overlaps it, the error and its
    autocorrelation too.
    """
    panels = drawers(data, truth, max_lag)
    if not panels:
        return []
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    heights = [3.0 if kind == "track" else 1.4 if name.startswith("stw ") else 1.0 for name, kind, _ in panels]
    fig, axes = plt.subplots(
        len(panels), 1, figsize=(10, 2.6 * sum(heights) + 1), height_ratios=heights, squeeze=False, layout="constrained"
    )
    try:
        time_axes = []
        kinds = [kind for _, kind, _ in panels]
        for i, (ax, (_name, kind, draw)) in enumerate(zip(axes[:, 0], panels)):
            draw(ax)
            if kind == "time":
                time_axes.append(ax)
                # Label the time axis wherever the next panel does not continue it.
                if i + 1 == len(panels) or kinds[i + 1] != "time":
                    ax.set_xlabel("minutes since start of recording")
        for ax in time_axes[:-1]:
            ax.sharex(time_axes[-1])
        fig.suptitle(title)
        fig.savefig(out, dpi=110)
    finally:
        plt.close(fig)
    return [name for name, _, _ in panels]
