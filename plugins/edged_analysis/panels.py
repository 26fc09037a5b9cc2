"""The panels of `edged plot`, one function each: what one matplotlib axis shows.

Per `/est/<name>` estimate of kind `stw`, the paper's figures: the estimate with its
shaded 1/2/3-σ band, the Doppler log, the filtered SOG and (second axis) the current
along the track, all in knots like the speed panel; against truth, the error stw −
truth with ±1/2/3 σ (Fig. 2) and the error's autocorrelation with the ±1.96/√n band
of a white error (Fig. 3). Each function takes the axis to draw on; matplotlib itself
is imported by `drawing`, only when a picture is made.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from edged.units import KNOT

from .figures import SIGMAS
from .plotdata import MARK_ORDER, PlotData, local_xy
from .stwdata import StwError, StwSeries, white_band
from .truth import Truth

__all__ = ["acf_panel", "error_panel", "marks_out_panel", "series_panel", "stw_panel", "track_panel"]

_KN = 1.0 / KNOT  # m/s -> knots, the unit of every speed panel


def track_panel(ax: Any, data: PlotData) -> None:
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


def series_panel(ax: Any, data: PlotData, key: str, ylabel: str, t0: float) -> None:
    for label, s in sorted(data.panel(key).items()):
        ax.plot([(t - t0) / 60.0 for t in s.t], s.y, lw=0.8, label=label)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize="small", loc="upper right")
    ax.grid(True, lw=0.3)


def marks_out_panel(ax: Any, data: PlotData, t0: float) -> None:
    """A tick at each estimate's time on the row of each mark it flagged `ok: false`."""
    for name, s in data.panel("marks_out").items():
        ax.plot([(t - t0) / 60.0 for t in s.t], s.y, "|", ms=6, label=name)
    ax.set_yticks(range(1, len(MARK_ORDER) + 1), MARK_ORDER, fontsize="small")
    ax.set_ylim(0.5, len(MARK_ORDER) + 0.5)
    ax.set_ylabel("marks out")
    ax.grid(True, lw=0.3)


def _minutes(t: Any, t0: float) -> Any:
    return (t - t0) / 60.0


def stw_panel(ax: Any, s: StwSeries, t0: float, truth: Truth | None) -> None:
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


def error_panel(ax: Any, e: StwError, t0: float) -> None:
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


def acf_panel(ax: Any, e: StwError, acf: Any) -> None:
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
