"""Keeping the filter consistent when the ship or the sensors are not what was assumed.

Seed 002's second named failure (§5.3): sudden rudder or engine orders break the
constant-turn-rate-and-acceleration assumption, the NIS leaves its χ² band for tens
of seconds and the estimates lag. Its proposed remedy, adapting Q, is `QScale`. The
innovations also tell how noisy each sensor really is; `NoiseEstimate` follows that
slowly, so that one default configuration suits a 1 m and a 3 m GNSS alike. Outliers
(a GNSS jump, a gyro glitch) are neither: `Gate` keeps them out.

QScale: over the last `window` seconds of updates (all sensors pooled), the summed
NIS is compared with the χ² 95 % band of the summed degrees of freedom. Above it,
the process noise of the manoeuvring states grows at the rate of the excess,

    s ← s · (ΣNIS / Σdof)^(Δt / τ_up),   at most `max_scale`;

inside or below it, s relaxes to 1 with time constant τ_down. The NIS a filter
reports is that of the Q it ran with, so s stops growing once the filter is
consistent again, and returns to 1 when the manoeuvre is over.

NoiseEstimate: per sensor (source and kind), covariance matching on the residuals
after the update (Mohamed & Schwarz 1999): ε = z − h(x⁺) and H P⁺ Hᵀ satisfy
E[ε εᵀ] + H P⁺ Hᵀ = R, and with the gain of the update ε = R S⁻¹ y and
H P⁺ Hᵀ = R − R S⁻¹ R, so each R_ii is an exponentially weighted mean of
(R S⁻¹ y)_i² + (R − R S⁻¹ R)_ii over about `samples` updates. Unlike matching the
innovations (y² − H P⁻ Hᵀ), no term is subtracted: an overstated P cannot drive R
to zero and the filter into overconfidence. Kept between a physical floor (no
GNSS is better than 5 cm, no gyro than 0.001°/s: `core.SIGMA_FLOOR`) and 25 × the
configured variance. Frozen while QScale is raised: a manoeuvre is not sensor noise.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from edged.innovation import chi2_band


_Z975 = 1.959963984540054


def band(dof: int) -> tuple[float, float]:
    """The χ² 95 % band of `dof` degrees of freedom: exact up to 60 (cached), then
    Wilson–Hilferty's cube-root normal approximation (error below 0.1 % there), since
    the pooled dof of a window changes at every update."""
    if dof <= 60:
        return chi2_band(dof)
    k = 2.0 / (9.0 * dof)
    return dof * (1.0 - k - _Z975 * math.sqrt(k)) ** 3, dof * (1.0 - k + _Z975 * math.sqrt(k)) ** 3


class QScale:
    def __init__(self, window: float = 2.0, tau_up: float = 1.0, tau_down: float = 10.0,
                 max_scale: float = 100.0) -> None:
        self.window = window
        self.tau_up = tau_up
        self.tau_down = tau_down
        self.max_scale = max_scale
        self.scale = 1.0
        self._q: deque[tuple[float, float, int]] = deque()
        self._sum_nis = 0.0
        self._sum_dof = 0
        self._t: float | None = None
        #: ΣNIS/Σdof over the window and whether it lies in the band (for health/output).
        self.ratio = 1.0
        self.in_band = True
        self.raised_s = 0.0

    def add(self, t: float, nis: float, dof: int) -> None:
        if not math.isfinite(nis):
            return
        q = self._q
        q.append((t, nis, dof))
        self._sum_nis += nis
        self._sum_dof += dof
        while q and q[0][0] < t - self.window:
            _, n0, d0 = q.popleft()
            self._sum_nis -= n0
            self._sum_dof -= d0
        dt = 0.0 if self._t is None else max(0.0, t - self._t)
        self._t = t
        if self._sum_dof < 4:
            return
        lo, hi = band(self._sum_dof)
        total = max(self._sum_nis, 0.0)
        self.ratio = total / self._sum_dof
        self.in_band = lo <= total <= hi
        if total > hi:
            self.scale = min(self.max_scale, self.scale * self.ratio ** (dt / self.tau_up))
            self.raised_s += dt
        elif self.scale > 1.0:
            self.scale = 1.0 + (self.scale - 1.0) * math.exp(-dt / self.tau_down)
            if self.scale < 1.0 + 1e-3:
                self.scale = 1.0

    def bump(self, factor: float) -> None:
        """A sensor kept out by its gate too long: the model, not the sensor, is wrong."""
        self.scale = min(self.max_scale, self.scale * factor)

    @property
    def raised(self) -> bool:
        return self.scale > 1.5

    def reset(self) -> None:
        self.scale = 1.0
        self._q.clear()
        self._sum_nis = 0.0
        self._sum_dof = 0
        self._t = None
        self.ratio, self.in_band = 1.0, True


class NoiseEstimate:
    """One sensor's measurement variance (diagonal), learned from its innovations."""

    def __init__(self, var0: np.ndarray, floor: np.ndarray, samples: float = 600.0, ceil: float = 25.0) -> None:
        self.var0 = np.asarray(var0, dtype=float)
        self.var = self.var0.copy()
        self.alpha = 1.0 / samples
        self.lo, self.hi = np.asarray(floor, dtype=float) ** 2, self.var0 * ceil
        self.n = 0

    def R(self) -> np.ndarray:
        return np.diag(self.var)

    def add(self, y: np.ndarray, S: np.ndarray, R: np.ndarray) -> None:
        """One applied update's innovation y, its covariance S and the R it used."""
        RSi = R @ np.linalg.inv(S) if S.shape[0] > 2 else R @ _inv(S)
        eps = RSi @ y
        sample = eps * eps + np.diag(R - RSi @ R)
        a = max(self.alpha, 1.0 / (self.n + 2))  # the first samples count more: a fast start
        self.var = np.clip((1 - a) * self.var + a * sample, self.lo, self.hi)
        self.n += 1

    def sigma(self) -> list[float]:
        return [float(math.sqrt(v)) for v in self.var]


def _inv(S: np.ndarray) -> np.ndarray:
    if S.shape == (1, 1):
        return np.array([[1.0 / S[0, 0]]])
    a, b, c, d = S[0, 0], S[0, 1], S[1, 0], S[1, 1]
    return np.array([[d, -b], [-c, a]]) / (a * d - b * c)


class Gate:
    """Per sensor: a measurement whose NIS is beyond the χ² quantile `p` is kept out;
    after `run` in a row it is let in (a real change, not an outlier) and says so."""

    def __init__(self, p: float = 0.9999, run: int = 5) -> None:
        self.p = p
        self.run = run
        self._limit: dict[int, float] = {}
        self.in_row = 0

    def limit(self, dof: int) -> float | None:
        if self.in_row >= self.run:
            return None  # let the next one in
        if dof not in self._limit:
            self._limit[dof] = chi2_band(dof, 2 * self.p - 1)[1]
        return self._limit[dof]

    def result(self, applied: bool) -> bool:
        """Record an update's outcome; True when it was let in after a run of rejects."""
        if applied:
            forced = self.in_row >= self.run
            self.in_row = 0
            return forced
        self.in_row += 1
        return False
