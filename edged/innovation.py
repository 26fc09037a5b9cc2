"""Innovation statistics of a Kalman filter, the way health reports them (DESIGN §6).

A consistent filter's normalised innovation squared (NIS, ν'S⁻¹ν) follows a χ²
distribution with as many degrees of freedom as the measurement has components: its
mean is the dof and 95 % of the values lie inside the two-sided χ² 95 % band. A filter
whose NIS mean drifts away from the dof, or whose share inside the band falls well
below 95 %, is mistuned or diverging (seed 002 monitors exactly this). Every estimator
keeps one `InnovationMonitor`, records each update, gate rejection and reset in it, and
returns `snapshot()` from its core's `health()`.
"""

from __future__ import annotations

import math
from collections import deque
from functools import cache
from typing import Any

__all__ = ["InnovationMonitor", "chi2_band"]


def _chi2_cdf(x: float, dof: int) -> float:
    """P(χ²_dof <= x): the regularised lower incomplete gamma P(dof/2, x/2), by its
    power series (converges for every x; a few hundred terms at most for the sizes of
    a filter's measurement vectors)."""
    if x <= 0.0:
        return 0.0
    s, z = dof / 2.0, x / 2.0
    term = 1.0 / s
    total = term
    n = 1
    while term > total * 1e-15 and n < 10_000:
        term *= z / (s + n)
        total += term
        n += 1
    return min(1.0, math.exp(s * math.log(z) - z - math.lgamma(s)) * total)


def _chi2_ppf(p: float, dof: int) -> float:
    lo, hi = 0.0, max(10.0, 10.0 * dof)
    while _chi2_cdf(hi, dof) < p:
        hi *= 2.0
    for _ in range(200):  # bisection to machine precision
        mid = 0.5 * (lo + hi)
        if _chi2_cdf(mid, dof) < p:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@cache
def chi2_band(dof: int, coverage: float = 0.95) -> tuple[float, float]:
    """The two-sided χ² interval holding `coverage` of a dof-degree χ² variable.

    Computed here rather than with scipy: importing scipy.stats takes about a second,
    which a worker process would spend in its first update.
    """
    if dof < 1:
        raise ValueError("dof must be >= 1")
    tail = (1.0 - coverage) / 2.0
    return _chi2_ppf(tail, dof), _chi2_ppf(1.0 - tail, dof)


class _KindStats:
    """One innovation kind's last `window` NIS values and whether each was in its band.

    Cheap per update (a draft core records one per reading, hundreds a second): the
    band is looked up once per dof, and the deques drop their oldest themselves."""

    __slots__ = ("dof", "lo", "hi", "nis", "inside", "updates", "gated")

    def __init__(self, window: int) -> None:
        self.dof = 1
        self.lo, self.hi = chi2_band(1)
        self.nis: deque[float] = deque(maxlen=window)
        self.inside: deque[bool] = deque(maxlen=window)
        self.updates = 0
        self.gated = 0

    def add(self, nis: float, dof: int) -> None:
        if dof != self.dof:  # a kind whose measurement size changed: start again
            self.dof = dof
            self.lo, self.hi = chi2_band(dof)
            self.nis.clear()
            self.inside.clear()
        self.nis.append(nis)
        self.inside.append(self.lo <= nis <= self.hi)
        self.updates += 1


class InnovationMonitor:
    """NIS per measurement kind over the last `window` updates, gate rejections, resets."""

    def __init__(self, window: int = 100) -> None:
        if window < 1:
            raise ValueError("window must be >= 1")
        self.window = window
        self._kinds: dict[str, _KindStats] = {}
        self.resets = 0
        self.last_reset: str | None = None
        self.last_reset_t: float | None = None

    def _stats(self, kind: str) -> _KindStats:
        s = self._kinds.get(kind)
        if s is None:
            s = self._kinds[kind] = _KindStats(self.window)
        return s

    def update(self, kind: str, nis: float, dof: int) -> None:
        """An accepted update of `kind` with its NIS and measurement dimension."""
        s = self._kinds.get(kind)
        (s if s is not None else self._stats(kind)).add(float(nis), int(dof))

    def gated(self, kind: str) -> None:
        """A measurement of `kind` the innovation gate rejected."""
        self._stats(kind).gated += 1

    def reset(self, reason: str, t: float | None = None) -> None:
        """The filter was reinitialised (divergence, a jump, a gap), and why."""
        self.resets += 1
        self.last_reset = reason
        self.last_reset_t = t

    def snapshot(self) -> dict[str, Any]:
        kinds: dict[str, Any] = {}
        for kind, s in self._kinds.items():
            n = len(s.nis)
            kinds[kind] = {
                "dof": s.dof,
                "updates": s.updates,
                "gated": s.gated,
                "window": n,
                "nis_mean": (sum(s.nis) / n) if n else None,
                "in_band_95": (sum(s.inside) / n) if n else None,
            }
        return {
            "innovation": kinds,
            "resets": self.resets,
            "last_reset": self.last_reset,
            "last_reset_t": self.last_reset_t,
        }
