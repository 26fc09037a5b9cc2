"""The speed-through-water figures of `edged plot` (the paper's), as arrays.

`StwSeries` is one `/est/<name>` channel of kind `stw` (`est/stw`, `est/stw_paper`,
...), in SI (m/s; the drawing converts): the estimate with its σ, the Doppler log, the
filtered SOG and the current along the track. Against a truth table (`truth.read_truth`,
the simulator's `truth.csv`): `stw_error` (estimate − truth, only where the truth's time
span covers the estimate) and `error_autocorrelation` at lags 0..N samples with
`white_band`, the ±1.96/√n band a white error stays inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .figures import autocorrelation, field_errors, figures
from .truth import Truth
from .values import finite

__all__ = ["ACF_LAGS", "STW_FIELDS", "StwError", "StwRows", "StwSeries", "error_autocorrelation", "stw_error", "white_band"]

#: The fields of an `stw` estimate the STW panel draws (DESIGN §6 `est/stw`), all m/s.
STW_FIELDS: tuple[str, ...] = ("stw", "stw_std", "dvl_stw", "sog", "current_along")
#: Default number of lags of the error autocorrelation panel (samples: seconds at 1 Hz).
ACF_LAGS = 120


@dataclass(frozen=True)
class StwSeries:
    """One `stw` estimate instance (`/est/<name>`) as arrays in time order, SI units
    (m/s); NaN where a value is null or absent. `stale`: the estimate's `stale` flag."""

    name: str
    t: np.ndarray
    stale: np.ndarray
    values: dict[str, np.ndarray]

    @property
    def stw(self) -> np.ndarray:
        return self.values["stw"]

    @property
    def stw_std(self) -> np.ndarray:
        return self.values["stw_std"]

    def has(self, key: str) -> bool:
        """Whether the field has at least one value."""
        return bool(np.isfinite(self.values[key]).any())


class StwRows:
    """What is gathered of one stw instance, message by message, before it becomes a
    StwSeries."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.stale: list[bool] = []
        self.values: dict[str, list[float]] = {k: [] for k in STW_FIELDS}

    def add(self, t: float, payload: dict[str, Any]) -> None:
        self.t.append(t)
        self.stale.append(payload.get("stale") is True)
        for k in STW_FIELDS:
            v = finite(payload.get(k))
            self.values[k].append(math.nan if v is None else v)

    def series(self, name: str) -> StwSeries:
        t = np.asarray(self.t, dtype=float)
        order = np.argsort(t, kind="stable")
        vals = {k: np.asarray(v, dtype=float)[order] for k, v in self.values.items()}
        return StwSeries(name, t[order], np.asarray(self.stale, dtype=bool)[order], vals)


@dataclass(frozen=True)
class StwError:
    """`stw − truth.stw` (m/s) of one instance at the samples that can be judged: those
    with an estimate, inside the truth's time span, where the truth is known. `std`:
    the estimate's own 1-σ at those samples (NaN where it published none)."""

    name: str
    t: np.ndarray
    err: np.ndarray
    std: np.ndarray

    @property
    def n(self) -> int:
        return int(self.err.size)

    def within(self) -> tuple[float | None, ...]:
        """% of errors inside ±1/2/3σ (figures.SIGMAS), of the samples with a σ."""
        return figures(self.err, self.std).within

    @property
    def rmse(self) -> float | None:
        return figures(self.err).rmse


def stw_error(s: StwSeries, truth: Truth) -> StwError:
    """The estimate's error against truth, the way `edged score` takes it (truth
    interpolated linearly to each estimate's time, nothing extrapolated)."""
    err, idx = field_errors(truth, "stw", s.t, s.stw)
    return StwError(s.name, s.t[idx], err, s.stw_std[idx])


def error_autocorrelation(err: np.ndarray, max_lag: int = ACF_LAGS) -> np.ndarray:
    """The sample autocorrelation r_k of `err` (time order) for k = 0..max_lag, as
    `figures.autocorrelation` defines it (biased estimator, r_0 = 1); lags the series
    is too short for are left out (the result is shorter). Empty for a series that
    does not vary: a constant error has no correlation to show."""
    x = np.asarray(err, dtype=float)
    if x.size < 2 or autocorrelation(x, 1) is None:
        return np.empty(0)
    top = min(max_lag, x.size - 1)
    out = [1.0]
    for k in range(1, top + 1):
        r = autocorrelation(x, k)
        out.append(math.nan if r is None else r)
    return np.asarray(out, dtype=float)


def white_band(n: int) -> float:
    """±1.96/√n: where about 95 % of a white series' autocorrelations lie (lag ≥ 1)."""
    return 1.96 / math.sqrt(n) if n > 0 else math.inf
