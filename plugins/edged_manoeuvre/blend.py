"""Which prediction to trust, per horizon, learned on the vessel's own track.

Why: a model run ahead is the best predictor of a ship in a steady turn (seed 002's
"advanced ship predictor"), and the worst one of a yacht whose 1 Hz compass swings ±5°
with the waves: the yaw rate the filter sees then is the wave's, ±5–15 °/s, and held
for a minute it turns the prediction through 120–360° (Aava: 8× the error of dead
reckoning at 30 s). The honest baseline of a short-term predictor is dead reckoning,
the last fix carried forward at the last SOG/COG. No configuration knows in advance
which vessel, sea and helmsman it will have; the track does, a minute later.

How: per horizon, a few candidate predictions are made at each prediction time (the
model with its yaw rate held, the model with the low-frequency yaw rate, dead
reckoning). When a fix shows where the vessel was at their due time, each candidate's
error e_i (a 2-vector, m) is kept for `window` seconds. The published prediction is the
combination Σ w_i·p_i with Σ w_i = 1, w_i ≥ 0 that minimises the windowed squared error

    J(w) = Σ_samples |Σ_i w_i e_i|² = wᵀ G w,    G_ij = Σ_samples e_i · e_j,

the forecast combination of Bates and Granger (*The combination of forecasts*, Oper.
Res. Q. 20, 1969) with the weights constrained to the simplex, so that it is never
worse over the window than the best single candidate (each vertex of the simplex is
one candidate alone): in particular never worse than dead reckoning. The minimum over
the simplex is found exactly by trying every subset of candidates: on a subset the
unconstrained minimum is w = G⁻¹1 / 1ᵀG⁻¹1; the best feasible one wins. Until
`min_samples` errors have come due, and until they span `min_span` horizons (errors of
predictions made a second apart for a minute ahead are nearly one error: a 60-s
prediction judged on its first 20 s of due errors took Aava's model at 80 s and made the
whole log's 60-s prediction 1.05x dead reckoning; 0.99x with 2 horizons), dead
reckoning alone is published, and so it is when the best combination's squared error
over the window is not at least `margin`
(25 %) below dead reckoning's: the weights are fitted to the window and applied to the
next minutes, and a small gain in the window is a loss as often as not after it
(Aava's 30-s prediction: 1.05× dead reckoning with every gain taken, 1.01× with 25 %).
"""

from __future__ import annotations

import itertools
import math
from collections import deque

import numpy as np


class ForecastBlend:
    """One horizon's candidates waiting to come due, the window of their errors, and
    the weights they give."""

    def __init__(self, horizon: float, names: tuple[str, ...], fallback: str, window: float = 600.0,
                 min_samples: int = 20, margin: float = 0.25, min_span: float = 2.0) -> None:
        self.margin = margin
        self.min_span = min_span
        self.horizon = horizon
        self.names = names
        self.n = len(names)
        self.window = window
        self.min_samples = min_samples
        self._fallback = names.index(fallback)
        self._pending: deque[tuple[float, np.ndarray]] = deque()  # (due, candidates' lat/lon (n, 2))
        self._errors: deque[tuple[float, np.ndarray]] = deque()  # (t due, errors (n, 2))
        self._G = np.zeros((self.n, self.n))
        self.weights = np.eye(self.n)[self._fallback]
        self.samples = 0
        self.rms = np.full(self.n, math.nan)  # each candidate's RMS error over the window
        self._subsets = _subsets(self.n)

    def add(self, t: float, latlon: np.ndarray) -> None:
        """The candidates (n × [lat, lon]) made at t for t + horizon."""
        self._pending.append((t + self.horizon, np.array(latlon, dtype=float)))

    def due(self, t: float, to_ne, position: tuple[float, float], velocity: tuple[float, float]) -> int:
        """Judge every prediction due by t against a fix at t (moved back along the
        velocity to the due time); `to_ne` maps lat, lon into the fix's plane."""
        n = 0
        while self._pending and self._pending[0][0] <= t + 1e-9:
            t_due, cands = self._pending.popleft()
            back = t - t_due
            wn = position[0] - velocity[0] * back
            we = position[1] - velocity[1] * back
            e = np.array([[pn - wn, pe - we] for pn, pe in (to_ne(float(a), float(b)) for a, b in cands)])
            if not np.all(np.isfinite(e)):
                continue
            self._errors.append((t_due, e))
            self._G += e @ e.T
            n += 1
        if n:
            while self._errors and self._errors[0][0] < t - self.window:
                _, old = self._errors.popleft()
                self._G -= old @ old.T
            self.samples = len(self._errors)
            self.rms = np.sqrt(np.maximum(np.diag(self._G), 0.0) / max(self.samples, 1))
            span = self._errors[-1][0] - self._errors[0][0]
            learned = self.samples >= self.min_samples and span >= self.min_span * self.horizon
            self.weights = self._solve() if learned else np.eye(self.n)[self._fallback]
        return n

    def _solve(self) -> np.ndarray:
        """argmin wᵀGw on the simplex, by every subset's unconstrained minimum.

        The subsets of one size are solved in one stacked `np.linalg.solve` (the same
        LAPACK call per matrix as one at a time, without its Python overhead for each
        of the 31 subsets of 5 candidates); a stack with a singular matrix is solved one
        matrix at a time, that one left out. Sums, traces, the feasibility test and the
        feasible weights are taken over the stack with the same operations in the same
        order as for one subset, so that the weights are the same to the last bit (a
        test compares them with the one-at-a-time search); only each candidate's
        squared error wᵀGw is taken one at a time (BLAS's own product)."""
        G = self._G / self.samples
        best, best_j = np.eye(self.n)[self._fallback], float(G[self._fallback, self._fallback])
        for k, idx, rows, cols, eye, ones, at in self._subsets:
            gs = G[rows, cols]  # (m, k, k): every subset's block of G
            scale = 1e-9 * (gs.trace(axis1=1, axis2=2) / k + 1e-12)
            gs = gs + eye * scale[:, None, None]  # equal candidates: singular
            A, solved = _solve_each(gs, ones)
            sums = A.sum(axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                W = A / sums[:, None]
            usable = np.flatnonzero(solved & (sums > 0.0) & ~(W < -1e-12).any(axis=1))
            if not usable.size:
                continue
            ws = np.zeros((usable.size, self.n))  # each feasible subset's weights, on all candidates
            ws[at[: usable.size], idx[usable]] = np.maximum(W[usable], 0.0)  # np.clip(·, 0, None)
            ws /= ws.sum(axis=1)[:, None]
            for w in ws:
                j = float(w @ G @ w)
                if j < best_j - 1e-12:
                    best, best_j = w, j
        if best_j > (1.0 - self.margin) * float(G[self._fallback, self._fallback]):
            return np.eye(self.n)[self._fallback]  # not worth what the window cannot promise
        return best.copy()

    def forget_pending(self) -> None:
        """The filter started again: its earlier predictions are not this filter's."""
        self._pending.clear()

    def combine(self, latlon: np.ndarray) -> tuple[float, float]:
        """The weighted prediction of candidates (n × [lat, lon]) made now (a few km at
        most apart: linear in degrees is linear in metres)."""
        w = self.weights
        return float(w @ latlon[:, 0]), float(w @ latlon[:, 1])

    def report(self) -> dict:
        return {"samples": self.samples, "weights": {n: round(float(w), 3) for n, w in zip(self.names, self.weights)},
                "rms": {n: (None if not math.isfinite(r) else round(float(r), 2)) for n, r in zip(self.names, self.rms)}}


def _subsets(n: int) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Per size k: the subsets of range(n) in `itertools.combinations` order (m × k
    indices), with the row and column indices that take their k × k blocks of G at
    once, eye(k), the right-hand sides 1 (m × k × 1) and the rows' numbers (m × 1)."""
    out = []
    for k in range(1, n + 1):
        idx = np.array(list(itertools.combinations(range(n), k)), dtype=np.intp)
        m = len(idx)
        out.append((k, idx, idx[:, :, None], idx[:, None, :], np.eye(k), np.ones((m, k, 1)), np.arange(m)[:, None]))
    return out


def _solve_each(gs: np.ndarray, ones: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """g⁻¹1 of every block of the stack (`ones` its right-hand sides), and which blocks
    could be solved (a singular one's row is NaN and marked False)."""
    try:
        return np.linalg.solve(gs, ones)[..., 0], np.ones(len(gs), bool)
    except np.linalg.LinAlgError:
        A = np.full(ones.shape[:2], np.nan)
        solved = np.zeros(len(gs), bool)
        for i, g in enumerate(gs):
            try:
                A[i] = np.linalg.solve(g, ones[i, :, 0])
                solved[i] = True
            except np.linalg.LinAlgError:
                pass
        return A, solved
