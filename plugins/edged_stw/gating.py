"""Innovation (Mahalanobis) gates, the covariance cap and the Schmidt update; the plain
Kalman equations are `kalman.py`'s."""

from __future__ import annotations

import numpy as np

from .kalman import identity, innovation

__all__ = ["innovation", "cap_variance", "consider_update"]


def cap_variance(P: np.ndarray, idx: slice, var_max: float) -> np.ndarray:
    """Scale rows and columns `idx` so that no variance there exceeds `var_max`.

    D·P·D with D diagonal keeps P positive semi-definite and the correlations as they
    were; used so that a state that nothing observes (the current without forecasts)
    says "unknown, within physical bounds" instead of growing without limit.
    Nearly always nothing is over the cap: that is decided from the diagonal alone
    (a NaN is not over it, as before) and P comes back as it was.
    """
    lo, hi, _ = idx.indices(P.shape[0])
    for i in range(lo, hi):
        if P[i, i] > var_max:
            break
    else:
        return P
    d = np.ones(P.shape[0])
    v = np.diag(P)[idx]
    d[idx] = np.where(v > var_max, np.sqrt(var_max / np.maximum(v, 1e-300)), 1.0)
    if np.all(d == 1.0):
        return P
    return P * np.outer(d, d)


def consider_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray, H: np.ndarray,
                    held: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A Schmidt ("consider") Kalman update: the optimal gain K = PHᵀS⁻¹ with its
    component along each column of `held` removed, K ← (I − A Aᵀ) K for the orthonormal
    columns A of `held` (n × m), then the Joseph form
        P' = (I − KH) P (I − KH)ᵀ + K R Kᵀ,
    which is the covariance of the update for *any* gain. The held directions of the
    state are not moved by this measurement, but their uncertainty still enters the
    innovation covariance S and the cross-covariances stay right, so P' does not claim
    more than the measurement gave. Why: a measurement that would observe a direction
    only through errors the model does not carry (heading − course seeing the current
    *along* the ship through the heading's wander) must not be allowed to."""
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T
    K = K - held @ (held.T @ K)
    x = x + K @ (z - H @ x)
    I_KH = identity(P.shape[0]) - K @ H
    P = I_KH @ P @ I_KH.T + K @ R @ K.T
    return x, 0.5 * (P + P.T)
