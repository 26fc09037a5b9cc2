"""`edged plot FILE.mcap -o report.png`: the pictures an analyst wants.

Track on a local map (equirectangular metres around the mean position), STW vs DVL vs
SOG, manoeuvring states, drafts and trim: each panel only when the recording has its
data. matplotlib is an optional extra (`pip install 'edged[plot]'`).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path
from typing import Any, Callable

from mcap.exceptions import McapError

from ..plotdata import PlotData, collect, local_xy
from ._common import EXIT_OK, EXIT_USAGE, command, existing_file, fail

#: (panel key, y label) of the time-series panels, top to bottom.
_TIME_PANELS = [
    ("speed", "speed (kn)"),
    ("motion", "velocity (kn)"),
    ("rate", "deg/s, deg"),
    ("draft", "draft (m)"),
    ("trim", "trim, list (m)"),
]


def _have_matplotlib() -> bool:
    return importlib.util.find_spec("matplotlib") is not None


def _track(ax: Any, data: PlotData) -> None:
    all_lat = [la for lats, _ in data.tracks.values() for la in lats]
    all_lon = [lo for _, lons in data.tracks.values() for lo in lons]
    lat0 = sum(all_lat) / len(all_lat)
    lon0 = sum(all_lon) / len(all_lon)
    for label, (lats, lons) in sorted(data.tracks.items()):
        xs, ys = local_xy(lats, lons, lat0, lon0)
        ax.plot(xs, ys, lw=1.0, label=label)
        ax.plot(xs[:1], ys[:1], "o", ms=4, color=ax.lines[-1].get_color())
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(f"track around {lat0:.5f}°, {lon0:.5f}° (o = start)")
    ax.legend(fontsize="small")
    ax.grid(True, lw=0.3)


def _series(ax: Any, data: PlotData, key: str, ylabel: str, t0: float) -> None:
    for label, s in sorted(data.panel(key).items()):
        ax.plot([(t - t0) / 60.0 for t in s.t], s.y, lw=0.8, label=label)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize="small", loc="upper right")
    ax.grid(True, lw=0.3)


def render(data: PlotData, out: Path, title: str) -> list[str]:
    """Draw the panels that have data into `out` (PNG); return their names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    drawers: list[tuple[str, Callable[[Any], None]]] = []
    if data.tracks:
        drawers.append(("track", lambda ax: _track(ax, data)))
    t0 = data.t0 or 0.0
    for key, ylabel in _TIME_PANELS:
        if data.panel(key):
            drawers.append((key, lambda ax, k=key, y=ylabel: _series(ax, data, k, y, t0)))
    if not drawers:
        return []
    heights = [3.0 if name == "track" else 1.0 for name, _ in drawers]
    fig, axes = plt.subplots(
        len(drawers), 1, figsize=(10, 2.6 * sum(heights) + 1), height_ratios=heights, squeeze=False, layout="constrained"
    )
    try:
        time_axes = []
        for ax, (name, draw) in zip(axes[:, 0], drawers):
            draw(ax)
            if name != "track":
                time_axes.append(ax)
        for ax in time_axes[:-1]:
            ax.sharex(time_axes[-1])
        if time_axes:
            time_axes[-1].set_xlabel("minutes since start of recording")
        fig.suptitle(title)
        fig.savefig(out, dpi=110)
    finally:
        plt.close(fig)
    return [name for name, _ in drawers]


@command("plot")
def main(args: argparse.Namespace) -> int:
    if not _have_matplotlib():
        return fail("plot needs matplotlib: pip install 'edged[plot]'")
    path = existing_file(args.file)
    if path is None:
        return EXIT_USAGE
    out = Path(args.output)
    try:
        data = collect(path)
        panels = render(data, out, path.name)
    except McapError as exc:
        return fail(f"{path}: {exc}")
    except OSError as exc:
        return fail(f"{exc.filename or out}: {exc.strerror or exc}")
    if not panels:
        return fail(f"{path}: nothing to plot (no positions, speeds, manoeuvre or draft data)")
    print(f"wrote {out}: {', '.join(panels)}", file=sys.stderr)
    return EXIT_OK
