"""The prediction ellipse's size, calibrated on the ship's own track.

Why: the ellipse comes from the model's covariance, and at 30 s ahead and more that is
mostly the configured process noise propagated: a guess for any vessel. Measured (10
runs of the simulator's Williamson turn): with the yaw and jerk noise ten times the
default, 98–100 % of the truths fell inside the 2-σ ellipse at 30–120 s; with a tenth,
53–76 %, where a Gaussian puts 86.5 %. A tanker and a launch differ by more than that.

How: each horizon keeps the model's ellipse (its shape and orientation: the model knows
along-track from cross-track) and scales it by k_h, chosen so that among the predictions
of the last `window` seconds that have come due, the share the GNSS fixes found inside
the `sigmas`-multiple ellipse is the Gaussian one, 1 − e^(−sigmas²/2). This is the
quantile of split conformal prediction (Vovk, Gammerman and Shafer, *Algorithmic
Learning in a Random World*, 2005) over a sliding window, which follows a changing
process as adaptive conformal inference does (Gibbs and Candès, NeurIPS 2021). It learns
from this ship, her sea and how she is being handled, and holds no figure of a
simulator. With the noise ten times off either way, the 2-σ ellipse then held 80–90 %.

Which multiple: errors minutes ahead are heavy-tailed (most predictions, made while the
ship goes on doing what she does, land close; the few made just before an order nobody
could foresee land far off), so no Gaussian ellipse holds both 39.3 % in 1σ and 86.5 %
in 2σ. Sized at 1σ it held 45–55 % there but only 60–70 % in 2σ; sized at 2σ (the
default), 86 % in 2σ and 72–74 % in 1σ. A CPA check or a berthing margin reads the outer
region, and there too small is the dangerous side.

The witness is a GNSS fix, not the filter's own later estimate: that shares the
prediction's errors (measured, it shrank the 10-s ellipse to hold 30 % in 1σ). The fix's
covariance B (its learned noise) is added to the scaled one: for the error e of a
prediction with model covariance A, the fix is inside when eᵀ(s·A + B)⁻¹e ≤ 1 with
s = k² (e divided by the multiple first). For 2 × 2 matrices that is a quadratic in s,
solved once when the prediction comes due:

    det(sA + B) − eᵀ adj(sA + B) e = 0
    s² det A + s (tr(adj(A) B) − eᵀ adj(A) e) + det B − eᵀ adj(B) e = 0

its largest root s_i is the smallest scale that holds the sample (0 when B alone does),
and s is the window's quantile of the s_i.

Which quantile: the Gaussian share holds in the window, but a window's quantile applied
to the next minutes holds less when the errors change (a manoeuvre, a sea getting up:
Aava's 600 s held 79.6 % at 10 s where the window held 86.5 %). Adaptive conformal
inference (Gibbs and Candès 2021) moves the quantile's level with each sample that
comes due, level += γ·(miss − (1 − p)), miss = 1 when the scale in use did not hold it:
over a run the share held is then p, whatever the errors do.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from typing import Callable

import numpy as np

#: The share of truths inside a 2-D Gaussian's 1-σ ellipse.
P_INSIDE = 1.0 - math.exp(-0.5)


def scale_to_hold(e: np.ndarray, A: np.ndarray, B: np.ndarray) -> float:
    """The smallest s ≥ 0 with eᵀ(sA + B)⁻¹e ≤ 1 (module docstring); inf if none."""
    a11, a12, a22 = float(A[0, 0]), 0.5 * float(A[0, 1] + A[1, 0]), float(A[1, 1])
    b11, b12, b22 = float(B[0, 0]), 0.5 * float(B[0, 1] + B[1, 0]), float(B[1, 1])
    e1, e2 = float(e[0]), float(e[1])
    det_a = a11 * a22 - a12 * a12
    det_b = b11 * b22 - b12 * b12
    adj_a_e = a22 * e1 * e1 - 2.0 * a12 * e1 * e2 + a11 * e2 * e2  # eᵀ adj(A) e
    adj_b_e = b22 * e1 * e1 - 2.0 * b12 * e1 * e2 + b11 * e2 * e2
    tr_adj_a_b = a22 * b11 + a11 * b22 - 2.0 * a12 * b12
    qa, qb, qc = det_a, tr_adj_a_b - adj_a_e, det_b - adj_b_e
    if qa <= 0.0:  # a degenerate ellipse: the quadratic is a line
        if qc >= 0.0 and det_b > 0.0:
            return 0.0
        return -qc / qb if qb > 0.0 else math.inf
    disc = qb * qb - 4.0 * qa * qc
    if disc < 0.0:
        return 0.0  # inside at every s
    # d² falls as s grows: the sample is held from the largest root on (0 when B alone
    # holds it: then qc > 0 and both roots are negative)
    return max(0.0, (-qb + math.sqrt(disc)) / (2.0 * qa))


class EllipseCalibration:
    """One horizon's scale: predictions waiting to come due, and the window of the
    scales that would have held those that did."""

    def __init__(self, horizon: float, window: float = 600.0, min_samples: int = 20, sigmas: float = 2.0,
                 gamma: float = 0.01) -> None:
        self.horizon = horizon
        self.gamma = gamma
        self.sigmas = sigmas
        self.p_inside = 1.0 - math.exp(-0.5 * sigmas * sigmas)
        self.level = self.p_inside  # the window quantile's level (ACI: moved by each miss)
        self.window = window
        self.min_samples = min_samples
        self._pending: deque[tuple[float, float, float, np.ndarray]] = deque()  # due, lat, lon, A
        self._held: deque[tuple[float, float]] = deque()  # (t due, s_i), in time order
        self._sorted: list[float] = []
        self.scale = 1.0  # k (on σ), 1 until min_samples have come due
        self.samples = 0

    def add(self, t: float, lat: float, lon: float, A: np.ndarray) -> None:
        """A prediction made at t for t + horizon, with its model covariance A (m², north/east)."""
        self._pending.append((t + self.horizon, lat, lon, np.array(A, dtype=float)))

    def due(self, t: float, to_ne: Callable[[float, float], tuple[float, float]], position: tuple[float, float],
            velocity: tuple[float, float], B: np.ndarray) -> int:
        """Compare each prediction due by t with a position witnessed at t (a GNSS fix,
        moved back along the estimated velocity to the due time) whose covariance is B;
        `to_ne` maps lat, lon into the witness's plane. Returns how many came due."""
        n = 0
        while self._pending and self._pending[0][0] <= t + 1e-9:
            t_due, lat, lon, A = self._pending.popleft()
            back = t - t_due
            pn, pe = to_ne(lat, lon)
            e = np.array([position[0] - velocity[0] * back - pn, position[1] - velocity[1] * back - pe])
            if not (np.all(np.isfinite(e)) and np.trace(B) < np.trace(A)):
                continue  # a surrogate no better than the prediction says nothing of it
            s = scale_to_hold(e / self.sigmas, A, B)
            if self.samples >= self.min_samples:
                miss = 1.0 if s > self.scale * self.scale else 0.0
                self.level = min(1.0, max(0.0, self.level + self.gamma * (miss - (1.0 - self.p_inside))))
            self._held.append((t_due, s))
            bisect.insort(self._sorted, s)
            n += 1
        if n:
            while self._held and self._held[0][0] < t - self.window:
                _, old = self._held.popleft()
                del self._sorted[bisect.bisect_left(self._sorted, old)]
            self.samples = len(self._sorted)
            if self.samples >= self.min_samples:
                # the smallest s holding at least P_INSIDE of the window
                k = min(self.samples - 1, max(0, math.ceil(self.level * self.samples) - 1))
                s = self._sorted[k]
                self.scale = math.sqrt(s) if math.isfinite(s) and s > 0.0 else self.scale
        return n

    def forget_pending(self) -> None:
        """The filter started again: its earlier predictions are not this filter's."""
        self._pending.clear()
