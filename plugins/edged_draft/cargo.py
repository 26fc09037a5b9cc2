"""Displacement change and cargo rate from the mean draft (seed 003 §3): a TPC or a
hydrostatic table turns metres of mean draft into tonnes, since a reference moment."""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from . import derived

NONE: dict[str, Any] = {"displacement_change": None, "displacement_change_std": None, "cargo_rate": None,
                        "cargo_rate_std": None}


def _slope_std(ts: np.ndarray, res: np.ndarray) -> float:
    """Standard error of a least-squares slope whose residuals are correlated (a
    filter's output once a second is): the samples count as n(1 − ρ)/(1 + ρ), ρ the
    residuals' lag-1 autocorrelation."""
    n = len(ts)
    var = float(np.dot(res, res)) / max(n - 2, 1)
    rho = float(np.dot(res[1:], res[:-1]) / np.dot(res, res)) if np.dot(res, res) > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99)
    n_eff = max(n * (1.0 - rho) / (1.0 + rho), 3.0)
    sxx = float(np.sum((ts - ts.mean()) ** 2))  # > 0: the ticks' times differ
    return math.sqrt(var / sxx * n / n_eff)


class Cargo:
    """The displacement change since the reference moment (the first mean draft after
    `reference_after` s) and its rate, with their 1-σ."""

    def __init__(self, cfg: Any) -> None:
        self.cfg = cfg
        self._reference: tuple[float, float] | None = None  # t, mean draft at the reference moment
        self._reference_std = 0.0
        self._first_mean_t: float | None = None
        self._history: deque[tuple[float, float]] = deque()  # (t, mean draft) for the cargo rate

    def at(self, t: float, mean_draft: float | None, mean_std: float | None) -> dict[str, Any]:
        """The cargo fields of the estimate at t (all null without a TPC or table)."""
        cfg = self.cfg
        if mean_draft is None or (cfg.tpc is None and not cfg.hydrostatics):
            return dict(NONE)
        if self._first_mean_t is None:
            self._first_mean_t = t
        if self._reference is None:
            if t - self._first_mean_t < cfg.reference_after:
                return dict(NONE)
            self._reference = (t, mean_draft)
            self._reference_std = mean_std or 0.0
        got = derived.displacement(mean_draft, cfg.tpc, cfg.hydrostatics, self._reference[1])
        if got is None:
            return dict(NONE)
        change, per_metre = got
        rate, rate_std = self._slope(t, mean_draft)
        change_std = per_metre * math.hypot(mean_std or 0.0, self._reference_std)
        return {"displacement_change": change, "displacement_change_std": change_std,
                "cargo_rate": None if rate is None else per_metre * rate * 3600.0,
                "cargo_rate_std": None if rate_std is None else per_metre * rate_std * 3600.0}

    def _slope(self, t: float, mean_draft: float) -> tuple[float | None, float | None]:
        """The mean draft's least-squares slope over the last `cargo_window` s (m/s),
        and its σ. An instant of the level's own rate wanders by ±0.7 mm/s in a 12-s
        sea: tens of thousands of t/h on a Capesize, where a discharge runs at a few
        thousand."""
        hist = self._history
        hist.append((t, mean_draft))
        while hist and hist[0][0] < t - self.cfg.cargo_window:
            hist.popleft()
        if len(hist) < 10:
            return None, None
        ts = np.array([h[0] for h in hist]) - t
        ds = np.array([h[1] for h in hist])
        slope, d0 = np.polyfit(ts, ds, 1)
        rate = float(slope)
        res = ds - (d0 + rate * ts)
        return rate, _slope_std(ts, res)
