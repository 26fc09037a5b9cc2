"""Errors against truth and what they say: the figures of `edged score` (ESTIMATORS
"Evaluation").

Pure functions of arrays, no file access, so that the figures are the same whoever
reads the inputs. Errors are `estimate − truth`; an angle's error is wrapped to
(−π, π] (`edged.angles.wrap_pi`).

An estimate kind with `lat`/`lon` (the manoeuvre kind) also gets a position error: the
horizontal distance from the true position in metres (`position_errors`). A distance
has no sign, so its "bias" is the mean distance, and it has no ±kσ figures (a 2-D error
is judged against an ellipse, not a 1-D σ).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from edged.angles import wrap_pi

from edged.geo import north_east
from .truth import Truth

__all__ = ["LAGS", "SIGMAS", "Figures", "autocorrelation", "figures", "field_errors", "position_errors"]

#: Lags (in samples) of the error autocorrelation: white errors give ≈ 0 at each.
LAGS: tuple[int, ...] = (1, 10, 60)
#: σ multiples of the coverage figures: a consistent σ gives 68.3 / 95.4 / 99.7 %.
SIGMAS: tuple[int, ...] = (1, 2, 3)


def field_errors(
    truth: Truth, column: str, t: np.ndarray, v: np.ndarray, angle: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Errors `v − truth` at the samples that can be judged, and those samples' indices.

    A sample is judged when its value is known (finite), its time lies in the truth's
    span and the interpolated truth is known; callers blank (NaN) what they leave out.
    """
    keep = np.flatnonzero(np.isfinite(v) & truth.covers(t))
    ref = truth.at(column, t[keep], 2.0 * math.pi if angle else None)
    ok = np.isfinite(ref)
    idx = keep[ok]
    err = v[idx] - ref[ok]
    return (wrap_pi(err) if angle else err), idx


def position_errors(
    truth: Truth, t: np.ndarray, lat: np.ndarray, lon: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal distance (m) from the true position at each sample, and the indices
    (`edged.geo.north_east` about the truth point)."""
    keep = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon) & truth.covers(t))
    tlat = truth.at("lat", t[keep])
    tlon = truth.at("lon", t[keep], 360.0)  # unwrapped: a track across the antimeridian
    ok = np.isfinite(tlat) & np.isfinite(tlon)
    idx = keep[ok]
    north, east = north_east(lat[idx], lon[idx], tlat[ok], tlon[ok])
    return np.hypot(north, east), idx


@dataclass(frozen=True)
class Figures:
    """What one error series says. None where a figure does not apply (no samples,
    no σ, a series shorter than the lag, a constant error)."""

    n: int
    rmse: float | None = None
    bias: float | None = None
    max_abs: float | None = None
    #: Samples with a σ (None: the field has no σ at all).
    n_sigma: int | None = None
    #: % of errors inside ±kσ for k in SIGMAS (of the n_sigma samples).
    within: tuple[float | None, ...] = (None,) * len(SIGMAS)
    #: Error autocorrelation at each of LAGS.
    ac: tuple[float | None, ...] = (None,) * len(LAGS)


def autocorrelation(x: np.ndarray, lag: int) -> float | None:
    """Sample autocorrelation r_k = Σ(x_i − x̄)(x_{i+k} − x̄) / Σ(x_i − x̄)².

    The usual (biased) estimator of a correlogram: bounded by 1, and for a white
    series |r_k| stays below about 2/√n. None when the series is not longer than the
    lag or does not vary (a constant error has no correlation to speak of; variation
    below 1e-9 of the error's size is rounding, not signal).
    """
    if lag < 1 or x.size <= lag:
        return None
    d = x - x.mean()
    den = float(d @ d)
    if den <= x.size * (1e-9 * float(np.abs(x).max())) ** 2:
        return None
    return float(d[:-lag] @ d[lag:]) / den


def figures(err: np.ndarray, sigma: np.ndarray | None = None) -> Figures:
    """The figures of an error series in time order; `sigma` the 1-σ at each sample
    (NaN where unknown: that sample is left out of the coverage only)."""
    n = int(err.size)
    n_sigma: int | None = None if sigma is None else 0
    if n == 0:
        return Figures(0, n_sigma=n_sigma)
    a = np.abs(err)
    within: tuple[float | None, ...] = (None,) * len(SIGMAS)
    if sigma is not None:
        ok = np.isfinite(sigma) & (sigma >= 0.0)
        n_sigma = int(ok.sum())
        if n_sigma:
            within = tuple(100.0 * float(np.mean(a[ok] <= k * sigma[ok])) for k in SIGMAS)
    return Figures(
        n,
        rmse=float(np.sqrt(np.mean(err * err))),
        bias=float(np.mean(err)),
        max_abs=float(a.max()),
        n_sigma=n_sigma,
        within=within,
        ac=tuple(autocorrelation(err, k) for k in LAGS),
    )
