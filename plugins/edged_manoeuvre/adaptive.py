"""Keeping the filter consistent when the ship or the sensors are not what was assumed.

Seed 002's second named failure (§5.3): sudden rudder or engine orders break the
constant-turn-rate-and-acceleration assumption, the NIS leaves its χ² band for tens
of seconds and the estimates lag. Its proposed remedy, adapting Q, is `QScale`. The
innovations also tell how noisy each sensor really is; `NoiseEstimate` follows that
slowly, so that one default configuration suits a 1 m and a 3 m GNSS alike. Outliers
(a GNSS jump, a gyro glitch) are neither: `Gate` keeps them out.

QScale: per group of states, base × boost. The boost reacts within a second when
the NIS of the last 2 s exceeds its χ² 95 % band (an order), and relaxes to 1 after;
the base follows the last minute's NIS either way, slowly, to the vessel's own agility.
The NIS a filter reports is that of the Q it ran with, so each stops moving once the
filter is consistent again.

NoiseEstimate: per sensor (source and kind), covariance matching on the residuals
after the update (Mohamed & Schwarz 1999): ε = z − h(x⁺) and H P⁺ Hᵀ satisfy
E[ε εᵀ] + H P⁺ Hᵀ = R, and with the gain of the update ε = R S⁻¹ y and
H P⁺ Hᵀ = R − R S⁻¹ R, so each R_ii is an exponentially weighted mean of
(R S⁻¹ y)_i² + (R − R S⁻¹ R)_ii over about `samples` updates. Unlike matching the
innovations (y² − H P⁻ Hᵀ), no term is subtracted: an overstated P cannot drive R
to zero and the filter into overconfidence. Kept between a physical floor (no
GNSS is better than 5 cm, no gyro than 0.001°/s: `update.SIGMA_FLOOR`) and 25 × the
configured variance. Frozen while QScale is raised: a manoeuvre is not sensor noise.
"""

from __future__ import annotations

import bisect
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


class _Window:
    """ΣNIS and Σdof of the updates of the last `span` seconds, and of at least
    `min_dof` degrees of freedom (a 1 Hz heading alone: its last four)."""

    __slots__ = ("span", "min_dof", "q", "nis", "dof")

    def __init__(self, span: float, min_dof: int) -> None:
        self.span = span
        self.min_dof = min_dof
        self.q: deque[tuple[float, float, int]] = deque()
        self.nis = 0.0
        self.dof = 0

    def add(self, t: float, nis: float, dof: int) -> None:
        q = self.q
        q.append((t, nis, dof))
        self.nis += nis
        self.dof += dof
        while q and q[0][0] < t - self.span and self.dof - q[0][2] >= self.min_dof:
            _, n0, d0 = q.popleft()
            self.nis -= n0
            self.dof -= d0

    def clear(self) -> None:
        self.q.clear()
        self.nis = 0.0
        self.dof = 0


class QScale:
    """The process-noise scale of one group of states: `base × boost`.

    boost (≥ 1, fast): over the last `window` seconds, ΣNIS above the χ² 95 % band of
    Σdof makes it grow as boost ← boost · (ΣNIS/Σdof)^(Δt/τ_up), up to `boost_cap`;
    below the band it falls as boost · (ΣNIS/Σdof)^(Δt/τ_fall) (an overshoot undone in
    seconds), and so it does when the short band holds it but the last 8 s, a tighter
    band of more samples, are below theirs (after an order, the NIS at 0.7 for half a
    minute lowered 50-run averages out of their band); inside both, while ΣNIS < Σdof,
    it relaxes to 1 with τ_down, and holds above (a steady turn keeps the boost it
    needs). A rudder or engine order, caught in a second.
    base (slow, either way): over the last `long_window` seconds, base ← base ·
    (ΣNIS/Σdof)^(Δt/τ), within [min_base, max_base], while boost is at rest (a
    stochastic approximation of ΣNIS = Σdof); and upward at the short window's rate
    while boost is at its cap. τ grows from τ_up to `tau_base` over the first
    `start_span` seconds: the configured level is a guess for any vessel and the
    first minute's NIS says better. The vessel's own agility: a 10 m launch yaws a
    hundred times harder than a tanker, and the configured noise is right for neither.
    """

    def __init__(self, window: float = 2.0, tau_up: float = 0.5, tau_down: float = 10.0, max_boost: float = 100.0,
                 long_window: float = 30.0, tau_base: float = 20.0, min_base: float = 1e-3,
                 max_base: float = 1e4, start_span: float = 120.0, tau_fall: float = 2.0) -> None:
        self.tau_up, self.tau_down, self.max_boost = tau_up, tau_down, max_boost
        self.tau_base, self.min_base, self.max_base = tau_base, min_base, max_base
        self.start_span = start_span
        self.tau_fall = tau_fall
        self._short = _Window(window, 4)
        self._long = _Window(long_window, 100)
        self._mid = _Window(8.0, 20)
        self.base = 1.0
        self.boost = 1.0
        self._t: float | None = None
        self._t0: float | None = None
        #: ΣNIS/Σdof over the short window and whether it lies in the band.
        self.ratio = 1.0
        self.in_band = True

    @property
    def scale(self) -> float:
        return self.base * self.boost

    @property
    def boost_cap(self) -> float:
        """`max_boost` above the configured level, or above the base when that is
        higher: after an hour of steady steaming has taken the base down a hundredfold,
        a hard-over order must still reach what the configuration allows in seconds."""
        return self.max_boost / min(self.base, 1.0)

    def add(self, t: float, nis: float, dof: int) -> None:
        if not math.isfinite(nis):
            return
        self._short.add(t, nis, dof)
        self._mid.add(t, nis, dof)
        self._long.add(t, nis, dof)
        dt = 0.0 if self._t is None else max(0.0, t - self._t)
        self._t = t
        if self._t0 is None:
            self._t0 = t
        w = self._short
        if w.dof < 4:
            return
        lo, hi = band(w.dof)
        total = max(w.nis, 0.0)
        self.ratio = total / w.dof
        self.in_band = lo <= total <= hi
        if total > hi:
            self.boost = min(self.boost_cap, self.boost * self.ratio ** (dt / self.tau_up))
            if self.boost >= self.boost_cap:  # the fast factor cannot hold it: the level moves
                self.base = min(self.max_base, self.base * self.ratio ** (dt / self.tau_base))
        elif self.boost > 1.0 and total < lo:
            # below the band: the boost overshot (an order is caught in a second, with
            # a factor of thousands); down as fast as the NIS says, not on the clock
            self.boost = max(1.0, self.boost * max(self.ratio, 0.01) ** (dt / self.tau_fall))
        elif self.boost > 1.0 and self._mid.dof >= 20 and self._mid.nis < band(self._mid.dof)[0]:
            # inside the short band, below the longer one's: the same fall, on more evidence
            mr = self._mid.nis / self._mid.dof
            self.boost = max(1.0, self.boost * max(mr, 0.01) ** (dt / self.tau_fall))
        elif self.boost > 1.0 and self.ratio < 1.0:
            self.boost = 1.0 + (self.boost - 1.0) * math.exp(-dt / self.tau_down)
            if self.boost < 1.0 + 1e-3:
                self.boost = 1.0
        if self.boost > 1.05 or self._long.dof < 100 or self._long.q[-1][0] - self._long.q[0][0] < 0.5 * self._long.span:
            return
        total = max(self._long.nis, 1e-9)
        # the first minutes count more (as a mean of few samples): the configured level
        # is a guess for any vessel, the NIS soon says better
        tau = max(self.tau_base * min(1.0, (t - self._t0) / self.start_span), self.tau_up)
        self.base = min(self.max_base, max(self.min_base, self.base * (total / self._long.dof) ** (dt / tau)))

    def bump(self, factor: float) -> None:
        """A sensor kept out by its gate too long: the model, not the sensor, is wrong."""
        self.boost = min(self.boost_cap, self.boost * factor)

    @property
    def raised(self) -> bool:
        return self.boost > 1.5

    def reset(self) -> None:
        self.boost = 1.0
        self._short.clear()
        self._mid.clear()
        self._long.clear()
        self._t = None
        self.ratio, self.in_band = 1.0, True


class NoiseEstimate:
    """One sensor's measurement variance (diagonal), learned from its innovations.

    A fast sensor averaged in blocks (`decimate.Decimator`) also gives its noise
    directly: each block's scatter about its line in time, over n, is the variance of
    its mean when the readings are independent. So the first `prime` blocks' mean
    scatter is the variance at once (matching the residuals from a conservative start
    takes minutes, the filter not yet telling sensor noise from motion), and the
    residuals take over from there: the scatter is no bound either way (correlated
    readings scatter less and average worse, a vibration faster than a block scatters
    more and averages out), so it is a start, not a floor. Measured (50 runs of
    `manoeuvre-williamson`): as a floor it held the accelerometers' NIS at 0.9."""

    def __init__(self, var0: np.ndarray, floor: np.ndarray, samples: float = 600.0, ceil: float = 25.0,
                 prime: int = 20) -> None:
        self.var0 = np.asarray(var0, dtype=float)
        self.var = self.var0.copy()
        self.alpha = 1.0 / samples
        self.lo, self.hi = np.asarray(floor, dtype=float) ** 2, self.var0 * ceil
        self.n = 0
        self.prime_blocks = prime
        self._scatter_sum = np.zeros_like(self.var0)
        self._scatter_n = 0
        self._R: tuple[np.ndarray, np.ndarray] | None = None  # (var, diag(var))

    def R(self) -> np.ndarray:
        """diag(var), read-only: made again only when var has changed (each change
        makes a new `var`)."""
        made = self._R
        if made is None or made[0] is not self.var:
            R = np.diag(self.var)
            R.flags.writeable = False
            self._R = made = (self.var, R)
        return made[1]

    @property
    def priming(self) -> bool:
        return 0 < self._scatter_n < self.prime_blocks

    def prime(self, scatter: np.ndarray | None) -> None:
        """One block's variance of its mean from its own readings (None: it had none)."""
        if scatter is None or scatter.shape != self.var.shape or self._scatter_n >= self.prime_blocks:
            return
        self._scatter_sum = self._scatter_sum + scatter
        self._scatter_n += 1
        self.var = np.clip(self._scatter_sum / self._scatter_n, self.lo, self.hi)
        self.n += 1

    def add(self, y: np.ndarray, S: np.ndarray, R: np.ndarray) -> None:
        """One applied update's innovation y, its covariance S and the R it used."""
        if self.priming:
            return
        if S.shape == (1, 1):  # one row, as scalars (the same products)
            r, y0 = float(R[0, 0]), float(y[0])
            rsi = r * (1.0 / float(S[0, 0]))
            eps = rsi * y0
            a = max(self.alpha, 1.0 / (self.n + 2))
            v = (1 - a) * float(self.var[0]) + a * (eps * eps + (r - rsi * r))
            self.var = np.array([min(max(v, float(self.lo[0])), float(self.hi[0]))])
            self.n += 1
            return
        RSi = R @ np.linalg.inv(S) if S.shape[0] > 2 else R @ _inv(S)
        eps = RSi @ y
        sample = eps * eps + (R - RSi @ R).diagonal()
        a = max(self.alpha, 1.0 / (self.n + 2))  # the first samples count more: a fast start
        # np.clip(·, lo, hi) as its two ufuncs (the same values: lo and hi are positive)
        self.var = np.minimum(np.maximum((1 - a) * self.var + a * sample, self.lo), self.hi)
        self.n += 1

    def ceiling(self, top: np.ndarray) -> None:
        """No more than `top` (the readings' own roughness says so, `Roughness`): when
        the process noise is raised, S ≫ R and the innovations cannot tell R (a
        0.001 °/s gyro stayed at the 0.05 °/s it was started from)."""
        self.var = np.minimum(np.maximum(np.minimum(self.var, top), self.lo), self.hi)  # np.clip (`add`)

    def sigma(self) -> list[float]:
        return [float(math.sqrt(v)) for v in self.var]


class Roughness:
    """An upper bound on a sensor's noise variance from its own readings alone.

    For readings z_k = s(t_k) + n_k at a steady interval Δt, the fourth difference
    d_k = z_{k+2} − 4 z_{k+1} + 6 z_k − 4 z_{k−1} + z_{k−2} has variance 70 σ_n² plus
    the signal's own, which is (ωΔt)⁴ of its amplitude for a motion of angular
    frequency ω: at 10 Hz a yacht's wave yaw of ±5 °/s at a 4-s period leaves 0.003 °/s
    of it, below a fibre-optic gyro's noise; the second difference would leave 0.1 °/s.
    So σ_n² ≤ E[d²]/70. The differences are taken over disjoint runs of five readings
    (overlapping ones are correlated at −0.8 and their median wanders by ±40 %); the
    median of the last `window` of them, over the median of χ²₁ (0.455), estimates
    E[d²] robustly (a spike moves a median by one rank), and SLACK covers a median's
    spread over a hundred samples. It bounds the learned R from above only: a signal
    that moves fast for its rate (a compass at 1 Hz on a yacht in a seaway) makes it
    loose, never wrong."""

    COEF = (1.0, -4.0, 6.0, -4.0, 1.0)
    GAIN = 70.0  # Σ COEF²
    SLACK = 1.5

    def __init__(self, window: int = 101) -> None:
        self.window = window
        self._z: deque[tuple[float, np.ndarray]] = deque(maxlen=len(self.COEF))
        self._d2: deque[list[float]] = deque()  # the last `window` squared differences, per row
        self._sorted: list[list[float]] = []  # the same, each row sorted (its median at hand)

    def add(self, t: float, z: np.ndarray, diff) -> np.ndarray | None:
        """One reading (`diff(a, b)` the kind's residual, angles wrapped); the bound on
        the variance per row once half a window of differences is in, else None."""
        self._z.append((t, np.asarray(z, dtype=float)))
        if len(self._z) < len(self.COEF):
            return None
        ts = [p[0] for p in self._z]
        steps = [b - a for a, b in zip(ts, ts[1:])]
        lo, hi = min(steps), max(steps)
        if lo <= 0.0 or hi - lo > 0.2 * hi:
            return None  # not a steady interval: the difference mixes in the signal's slope
        ref = self._z[2][1]  # differences about the middle reading (angles wrapped)
        d = sum(c * diff(zk, ref) for c, (_, zk) in zip(self.COEF, self._z))
        self._z.clear()  # the next difference from the next five readings
        self._push((d * d).tolist())
        if len(self._d2) < self.window // 2:
            return None
        return np.array([self.SLACK * _median(rows) / (self.GAIN * 0.455) for rows in self._sorted])

    def _push(self, d2: list[float]) -> None:
        """One squared difference into the window, the oldest out of it (each row's
        sorted list follows: a median of a hundred values without sorting them again)."""
        if not self._sorted:
            self._sorted = [[] for _ in d2]
        if len(self._d2) >= self.window:
            for rows, old in zip(self._sorted, self._d2.popleft()):
                del rows[bisect.bisect_left(rows, old)]
        self._d2.append(d2)
        for rows, v in zip(self._sorted, d2):
            bisect.insort(rows, v)


def _median(s: list[float]) -> float:
    """The median of sorted values, as `np.median` takes it: the middle one, or the mean
    of the middle two."""
    n = len(s)
    return s[n // 2] if n % 2 else (s[n // 2 - 1] + s[n // 2]) / 2


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
