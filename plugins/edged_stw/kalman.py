"""The linear Kalman filter's equations, written out once for every filter of this package.

Time update (Bar-Shalom, Li & Kirubarajan 2001, *Estimation with Applications to
Tracking and Navigation*, §5.2; Simon 2006, *Optimal State Estimation*, §5.1):
    x⁻ = F x + B u                                         (K1)
    P⁻ = F P Fᵀ + Q                                         (K2)
Measurement update, z = H x + v, v ~ N(0, R):
    y = z − H x⁻                   the innovation           (K3)
    S = H P⁻ Hᵀ + R                its covariance           (K4)
    ν = yᵀ S⁻¹ y                   NIS, what the gates test (K5)
    K = P⁻ Hᵀ S⁻¹                  the gain                 (K6)
    x = x⁻ + K y                                            (K7)
    P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ                   (K8)
(K8) is Joseph's form (Bucy & Joseph 1968): the covariance of the update for any gain,
symmetric and positive by construction, where P⁻ − K S Kᵀ loses both to rounding.
Process noise of a white noise of spectral density q on the highest derivative of an
integrator chain (continuous white noise, discretised exactly: Van Loan 1978,
"Computing integrals involving the matrix exponential"; Bar-Shalom §6.2), per axis:
    Q = q ∫₀ᵀ e^{As} b bᵀ e^{Aᵀs} ds
    white acceleration (p, v):     [[T³/3, T²/2], [T²/2, T]]                      (Q2)
    white jerk (p, v, a):          [[T⁵/20, T⁴/8, T³/6], [T⁴/8, T³/3, T²/2],
                                    [T³/6, T²/2, T]]                              (Q3)

Why our own (issue 34): filterpy's `predict`/`update` spent most of a step checking and
reshaping their arguments and inverting S through `np.linalg.inv`'s Python wrapper, and
importing `filterpy.kalman` pulls in scipy (0.6 s of every `edged replay`'s start). The
arithmetic here is the same numpy/LAPACK operations in the same order as filterpy's
(`np.dot` for every product, LAPACK's `gesv` for S⁻¹), so the estimates keep their
bits; what changed is what is done around them:
- a measurement of states i..i+m (H = rows of the identity) takes its rows and columns
  of P instead of multiplying by H (`innovation_rows`, `update_rows`: H·P, P·Hᵀ and
  K·H of a 0/1 matrix are those slices exactly);
- a scalar measurement (`innovation_scalar`, `update_scalar`) has S⁻¹ = 1/s, and K y,
  K H, K R Kᵀ are single products (outer products), exactly as the matrix forms gave;
- S⁻¹ and S⁻¹y come from numpy's LAPACK ufuncs without the wrapper's checks.
"""

from __future__ import annotations

import functools

import numpy as np

try:  # numpy's own LAPACK ufuncs, what np.linalg.inv / np.linalg.solve call, without
    # their argument checks and floating-point-state context (3 µs of each call).
    from numpy.linalg._umath_linalg import inv as _inv_ufunc
    from numpy.linalg._umath_linalg import solve1 as _solve1

    def _inv(S: np.ndarray) -> np.ndarray:
        """S⁻¹ (LAPACK gesv), float64 in and out (naming the loop saves its look-up)."""
        return _inv_ufunc(S, signature="d->d")
except ImportError:  # pragma: no cover - a numpy that moved them: the public wrappers
    _inv, _solve1 = np.linalg.inv, np.linalg.solve

__all__ = ["predict", "innovation", "update", "innovation_rows", "update_rows", "innovation_scalar",
           "update_scalar", "white_noise_q", "identity"]


@functools.lru_cache(maxsize=16)
def identity(n: int) -> np.ndarray:
    """I of size n, made once (read-only: shared)."""
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


def predict(x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray,
            Bu: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(K1), (K2). `Bu` is the control input B·u (0 without one: adding it also turns a
    −0.0 of F·x into +0.0, as filterpy's did)."""
    return np.dot(F, x) + Bu, np.dot(np.dot(F, P), F.T) + Q


def innovation(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray,
               H: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(K3)–(K5) for any H: the residual, its covariance and the NIS."""
    y = z - np.dot(H, x)
    S = np.dot(np.dot(H, P), H.T) + R
    return y, S, float(np.dot(y, _solve1(S, y)))


def update(x: np.ndarray, P: np.ndarray, y: np.ndarray, S: np.ndarray, R: np.ndarray,
           H: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K6)–(K8) for any H, given y and S of (K3), (K4)."""
    K = np.dot(np.dot(P, H.T), _inv(S))
    x = x + np.dot(K, y)
    I_KH = identity(P.shape[0]) - np.dot(K, H)
    return x, np.dot(np.dot(I_KH, P), I_KH.T) + np.dot(np.dot(K, R), K.T)


def innovation_rows(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray,
                    rows: slice) -> tuple[np.ndarray, np.ndarray, float]:
    """(K3)–(K5) for H = the identity's `rows` (states measured directly):
    H x = x[rows], H P Hᵀ = P[rows, rows]."""
    y = z - x[rows]
    S = P[rows, rows] + R
    return y, S, float(np.dot(y, _solve1(S, y)))


def update_rows(x: np.ndarray, P: np.ndarray, y: np.ndarray, S: np.ndarray, R: np.ndarray,
                rows: slice) -> tuple[np.ndarray, np.ndarray]:
    """(K6)–(K8) for H = the identity's `rows`: P Hᵀ = P[:, rows], and I − K H is the
    identity less K in those columns."""
    n = P.shape[0]
    K = np.dot(P[:, rows], _inv(S))
    x = x + np.dot(K, y)
    I_KH = identity(n) - np.dot(K, _rows_of_identity(n, rows.start, rows.stop))
    return x, np.dot(np.dot(I_KH, P), I_KH.T) + np.dot(np.dot(K, R), K.T)


@functools.lru_cache(maxsize=16)
def _rows_of_identity(n: int, start: int, stop: int) -> np.ndarray:
    """H of a measurement of states start..stop − 1 (read-only: shared)."""
    H = np.eye(n)[start:stop]
    H.flags.writeable = False
    return H


def innovation_scalar(x: np.ndarray, P: np.ndarray, z: float, r: float,
                      h: np.ndarray) -> tuple[float, float, float]:
    """(K3)–(K5) of one scalar z = h·x + v, var v = r: y, s and ν = y²/s (as y·(S⁻¹y))."""
    y = z - float(np.dot(h, x))
    s = float(np.dot(np.dot(h, P), h)) + r
    return y, s, y * (y / s)


def update_scalar(x: np.ndarray, P: np.ndarray, y: float, s: float, r: float,
                  h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K6)–(K8) of one scalar measurement: K = P h / s, K H = K hᵀ, K R Kᵀ = r K Kᵀ."""
    K = np.dot(P, h) * (1.0 / s)
    x = x + K * y
    I_KH = identity(P.shape[0]) - K[:, None] * h[None, :]
    Kr = K * r
    return x, np.dot(np.dot(I_KH, P), I_KH.T) + Kr[:, None] * K[None, :]


@functools.lru_cache(maxsize=256)
def white_noise_q(order: int, T: float) -> np.ndarray:
    """(Q2) (order 2) or (Q3) (order 3) for q = 1 and a step of T s (read-only, kept
    for each T seen lately: a sensor's interval repeats)."""
    if order == 2:
        Q = [[T**3 / 3.0, T**2 / 2.0], [T**2 / 2.0, T]]
    elif order == 3:
        Q = [[T**5 / 20.0, T**4 / 8.0, T**3 / 6.0],
             [T**4 / 8.0, T**3 / 3.0, T**2 / 2.0],
             [T**3 / 6.0, T**2 / 2.0, T]]
    else:
        raise ValueError(f"order {order}: 2 or 3")
    out = np.array(Q)
    out.flags.writeable = False
    return out
