"""`edged plot FILE.mcap [--truth truth.csv] -o report.png`: the pictures an analyst wants.

Track on a local map (equirectangular metres around the mean position), STW vs DVL vs
SOG, manoeuvring states, drafts and trim: each panel only when the recording has its
data. matplotlib is an optional extra (`pip install 'edged[plot]'`).

Per `/est/<name>` estimate of kind `stw`, the paper's figures: the estimate with its
shaded 1/2/3-σ band, the Doppler log, the filtered SOG and (second axis) the current
along the track, all in knots like the speed panel. With `--truth` (the simulator's
`truth.csv`): the true STW on that panel, the error stw − truth with ±1/2/3 σ (Fig. 2)
and the error's autocorrelation at lags 0..120 samples with the ±1.96/√n band of a
white error (Fig. 3). A truth file that is missing, not a truth table or without `t`
and `stw` columns is bad usage (exit 2, the message names it).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np
from mcap.exceptions import McapError

from edged.registry import Registry
from edged.subcommand import Subcommand

from ..plotdata import (
    ACF_LAGS,
    MARK_ORDER,
    PlotData,
    StwError,
    StwSeries,
    collect,
    error_autocorrelation,
    local_xy,
    read_truth,
    stw_error,
    white_band,
)
from ..scoring import SIGMAS, ScoreError, Truth
from ._common import EXIT_OK, EXIT_USAGE, existing_file, fail

_KN = 3600.0 / 1852.0  # m/s -> knots, the unit of every speed panel

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


def _marks_out(ax: Any, data: PlotData, t0: float) -> None:
    """A tick at each estimate's time on the row of each mark it flagged `ok: false`."""
    for name, s in data.panel("marks_out").items():
        ax.plot([(t - t0) / 60.0 for t in s.t], s.y, "|", ms=6, label=name)
    ax.set_yticks(range(1, len(MARK_ORDER) + 1), MARK_ORDER, fontsize="small")
    ax.set_ylim(0.5, len(MARK_ORDER) + 0.5)
    ax.set_ylabel("marks out")
    ax.grid(True, lw=0.3)


def _minutes(t: Any, t0: float) -> Any:
    return (t - t0) / 60.0


def _stw_panel(ax: Any, s: StwSeries, t0: float, truth: Truth | None) -> None:
    """The paper's estimate figure: STW with its shaded 1/2/3-σ band, DVL, SOG, truth;
    the current along the track on a second axis."""
    x = _minutes(s.t, t0)
    stw, std = s.stw * _KN, s.stw_std * _KN
    (line,) = ax.plot(x, stw, lw=0.9, label=f"STW est/{s.name}", zorder=3)
    if s.has("stw_std"):
        for k, alpha in zip(sorted(SIGMAS, reverse=True), (0.12, 0.2, 0.3)):
            ax.fill_between(x, stw - k * std, stw + k * std, color=line.get_color(), alpha=alpha, lw=0, label=f"±{k}σ")
    if s.has("dvl_stw"):
        ax.plot(x, s.values["dvl_stw"] * _KN, lw=0.7, label="DVL (log, not an input)")
    if s.has("sog"):
        ax.plot(x, s.values["sog"] * _KN, lw=0.7, label="SOG (filtered)")
    if truth is not None:
        inside = truth.covers(s.t)
        if inside.any():
            ax.plot(x[inside], truth.at("stw", s.t[inside]) * _KN, "k--", lw=0.7, label="STW truth")
    ax.set_ylabel("speed (kn)")
    ax.set_title(f"est/{s.name}: speed through water", fontsize="medium")
    handles, labels = ax.get_legend_handles_labels()
    if s.has("current_along"):
        cur = ax.twinx()
        (c,) = cur.plot(x, s.values["current_along"] * _KN, lw=0.7, color="tab:purple", label="current along track")
        cur.set_ylabel("current along (kn, + following)", color=c.get_color())
        h2, l2 = cur.get_legend_handles_labels()
        handles, labels = handles + h2, labels + l2
    ax.legend(handles, labels, fontsize="small", loc="upper right", ncol=2)
    ax.grid(True, lw=0.3)


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{v:.1f}"


def _error_panel(ax: Any, e: StwError, t0: float) -> None:
    """The paper's Fig. 2: the error against truth with ±1/2/3 σ of the estimate."""
    x = _minutes(e.t, t0)
    ax.plot(x, e.err * _KN, lw=0.7, color="tab:red", label="stw − truth")
    if np.isfinite(e.std).any():
        for k, style in zip(SIGMAS, (":", "--", "-")):
            ax.plot(x, k * e.std * _KN, style, lw=0.6, color="0.35", label=f"±{k}σ")
            ax.plot(x, -k * e.std * _KN, style, lw=0.6, color="0.35")
    ax.axhline(0.0, lw=0.4, color="k")
    within = "/".join(_pct(w) for w in e.within())
    rmse = e.rmse
    ax.set_title(
        f"est/{e.name}: error, n={e.n}, RMSE {rmse * _KN:.3f} kn ({rmse:.3f} m/s), "
        f"inside ±1/2/3σ {within} %",
        fontsize="medium",
    )
    ax.set_ylabel("error (kn)")
    ax.legend(fontsize="small", loc="upper right", ncol=4)
    ax.grid(True, lw=0.3)


def _acf_panel(ax: Any, e: StwError, acf: Any) -> None:
    """The paper's Fig. 3: the error's autocorrelation with the white-noise band."""
    lags = np.arange(acf.size)
    ax.vlines(lags, 0.0, acf, lw=1.0, color="tab:red")
    ax.plot(lags, acf, ".", ms=3, color="tab:red")
    band = white_band(e.n)
    ax.axhline(band, ls="--", lw=0.7, color="tab:blue", label=f"±1.96/√n (n={e.n})")
    ax.axhline(-band, ls="--", lw=0.7, color="tab:blue")
    ax.axhline(0.0, lw=0.4, color="k")
    step = float(np.median(np.diff(e.t))) if e.n > 1 else float("nan")
    ax.set_xlabel(f"lag (samples; median step {step:.3g} s)")
    ax.set_ylabel("autocorrelation")
    ax.set_title(f"est/{e.name}: autocorrelation of the error", fontsize="medium")
    ax.legend(fontsize="small", loc="upper right")
    ax.grid(True, lw=0.3)


def render(data: PlotData, out: Path, title: str, truth: Truth | None = None, max_lag: int = ACF_LAGS) -> list[str]:
    """Draw the panels that have data into `out` (PNG); return their names.

    With `truth`: per stw instance whose time overlaps it, the error and its
    autocorrelation too.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # (name, axis kind: track | time | lag, drawer)
    drawers: list[tuple[str, str, Callable[[Any], None]]] = []
    if data.tracks:
        drawers.append(("track", "track", lambda ax: _track(ax, data)))
    t0 = data.t0 or 0.0
    for key, ylabel in _TIME_PANELS[:1]:
        if data.panel(key):
            drawers.append((key, "time", lambda ax, k=key, y=ylabel: _series(ax, data, k, y, t0)))
    for name, s in data.stw.items():
        if not s.has("stw"):
            continue
        drawers.append((f"stw {name}", "time", lambda ax, s=s: _stw_panel(ax, s, t0, truth)))
        if truth is None:
            continue
        e = stw_error(s, truth)
        if not e.n:
            continue
        drawers.append((f"error {name}", "time", lambda ax, e=e: _error_panel(ax, e, t0)))
        acf = error_autocorrelation(e.err, max_lag)
        if acf.size:
            drawers.append((f"autocorrelation {name}", "lag", lambda ax, e=e, a=acf: _acf_panel(ax, e, a)))
    for key, ylabel in _TIME_PANELS[1:]:
        if data.panel(key):
            drawers.append((key, "time", lambda ax, k=key, y=ylabel: _series(ax, data, k, y, t0)))
    if data.panel("draft") and data.panel("marks_out"):
        drawers.append(("marks out", "time", lambda ax: _marks_out(ax, data, t0)))
    if not drawers:
        return []
    heights = [3.0 if kind == "track" else 1.4 if name.startswith("stw ") else 1.0 for name, kind, _ in drawers]
    fig, axes = plt.subplots(
        len(drawers), 1, figsize=(10, 2.6 * sum(heights) + 1), height_ratios=heights, squeeze=False, layout="constrained"
    )
    try:
        time_axes = []
        kinds = [kind for _, kind, _ in drawers]
        for i, (ax, (_name, kind, draw)) in enumerate(zip(axes[:, 0], drawers)):
            draw(ax)
            if kind == "time":
                time_axes.append(ax)
                # Label the time axis wherever the next panel does not continue it.
                if i + 1 == len(drawers) or kinds[i + 1] != "time":
                    ax.set_xlabel("minutes since start of recording")
        for ax in time_axes[:-1]:
            ax.sharex(time_axes[-1])
        fig.suptitle(title)
        fig.savefig(out, dpi=110)
    finally:
        plt.close(fig)
    return [name for name, _, _ in drawers]


def _truth_notes(data: PlotData, truth: Truth, path: Path) -> list[str]:
    """What the user asked for with --truth and will not see, and why."""
    notes = []
    if truth.bad_rows:
        notes.append(f"{truth.name}: {truth.bad_rows} bad row(s) skipped (not numbers, no time or wrong number of cells)")
    usable = {n: s for n, s in data.stw.items() if s.has("stw")}
    if not usable:
        notes.append(f"{path}: no estimate of kind stw (/est/<name>): --truth {truth.name} not used")
    for name, s in usable.items():
        if not stw_error(s, truth).n:
            notes.append(f"{truth.name}: no truth at the times of est/{name}: its error is not drawn")
    return notes


def main(args: argparse.Namespace, registry: Registry | None = None) -> int:
    if not _have_matplotlib():
        return fail("plot needs matplotlib: pip install 'edged[plot]'")
    path = existing_file(args.file)
    if path is None:
        return EXIT_USAGE
    truth: Truth | None = None
    truth_arg = getattr(args, "truth", None)
    if truth_arg is not None:
        try:
            truth = read_truth(Path(truth_arg))
        except ScoreError as exc:
            return fail(str(exc), EXIT_USAGE)
    out = Path(args.output)
    try:
        data = collect(path)
        if truth is not None:
            for note in _truth_notes(data, truth, path):
                print(f"edged: {note}", file=sys.stderr)
        panels = render(data, out, path.name, truth)
    except McapError as exc:
        return fail(f"{path}: {exc}")
    except OSError as exc:
        return fail(f"{exc.filename or out}: {exc.strerror or exc}")
    if not panels:
        return fail(f"{path}: nothing to plot (no positions, speeds, manoeuvre or draft data)")
    print(f"wrote {out}: {', '.join(panels)}", file=sys.stderr)
    return EXIT_OK


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE.mcap")
    p.add_argument("-o", "--output", required=True, metavar="report.png")
    p.add_argument("--truth", metavar="truth.csv",
                   help="truth table (the simulator's truth.csv): adds the STW error and its autocorrelation")


#: `edged plot` (entry point `edged.commands: plot`).
COMMAND = Subcommand("the pictures an analyst wants, as PNG", arguments, main)
