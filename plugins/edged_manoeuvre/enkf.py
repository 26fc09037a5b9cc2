"""Ensemble Kalman filter with perturbed observations (seed 004; Evensen 2003).

N members X_i (default 100) stand for the state's distribution:
predict   X_i ← RK4(X_i, Δt) + w_i,  w_i ~ N(0, Q_c·Δt)      (all members at once)
update    Z_i = h(X_i);  z̄ = mean Z_i (angle rows: circular);  A = X − x̄, B = Z − z̄
          (ψ and angle rows wrapped);  P_xz = AᵀB/(N−1),  S = BᵀB/(N−1) + R
          K = P_xz S⁻¹;  X_i ← X_i + K (z + e_i − Z_i),  e_i ~ N(0, R) (residual wrapped)
The estimate is the ensemble mean (ψ circular) and P its sample covariance, inflated
by `inflation` after each update (a small ensemble underestimates its spread).
NIS uses the ensemble's S and y = z − z̄ (eq. 25).

Ours, not filterpy's `EnsembleKalmanFilter`: that one fixes the measurement size and
function at construction and neither wraps angles nor takes circular means, so it can
neither update one sensor's rows at a time nor cross north. Randomness comes from a
seeded generator: the same log gives the same estimates.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from edged.angles import wrap_2pi, wrap_pi

from .cmm import Cmm
from .ctra import Ctra
from .filter import KalmanFilter
from .model import KINDS, PSI, Innovation, circular_mean, judge, residual, rk4


class Enkf(KalmanFilter):
    name: ClassVar[str] = "enkf"

    def __init__(self, model: Ctra | Cmm, x0: np.ndarray, P0: np.ndarray, substep: float, members: int = 100,
                 seed: int = 0, inflation: float = 1.0) -> None:
        self.model = model
        self.substep = substep
        self.inflation = inflation
        self.rng = np.random.default_rng(seed)
        self.X = self.rng.multivariate_normal(np.asarray(x0, dtype=float), P0, size=members, method="cholesky")
        self.X[:, PSI] = wrap_2pi(self.X[:, PSI])

    @property
    def x(self) -> np.ndarray:
        x = self.X.mean(axis=0)
        x[PSI] = circular_mean(self.X[:, PSI])
        return x

    @property
    def P(self) -> np.ndarray:
        A = self._anomalies()
        return A.T @ A / (len(self.X) - 1)

    def _anomalies(self) -> np.ndarray:
        A = self.X - self.X.mean(axis=0)
        A[:, PSI] = wrap_pi(self.X[:, PSI] - circular_mean(self.X[:, PSI]))
        return A

    def predict(self, dt: float, Qc: np.ndarray) -> None:
        if dt <= 0.0:
            return
        X = rk4(self.model.f, self.X, dt, self.substep)
        X += self.rng.standard_normal(X.shape) * np.sqrt(np.diag(Qc) * dt)
        X[:, PSI] = wrap_2pi(X[:, PSI])
        self.X = X

    def update(self, kind: str, z: np.ndarray, R: np.ndarray, gate: float | None = None) -> Innovation:
        k = KINDS[kind]
        X = self.X
        N = len(X)
        Z = self.model.h(kind, X)
        zbar = Z.mean(axis=0)
        for i in k.angle_rows:
            zbar[i] = circular_mean(Z[:, i])
        A = self._anomalies()
        B = residual(k, Z, zbar)
        S = B.T @ B / (N - 1) + R
        y = residual(k, np.asarray(z, dtype=float), zbar)
        nis, rc, apply = judge(y, S, gate)
        if not apply:
            return Innovation(y, S, nis, rc, False)
        K = np.linalg.solve(S, (A.T @ B / (N - 1)).T).T
        E = self.rng.multivariate_normal(np.zeros(k.dim), R, size=N, method="cholesky")
        D = residual(k, np.asarray(z, dtype=float) + E, Z)
        X = X + D @ K.T
        X[:, PSI] = wrap_2pi(X[:, PSI])
        if self.inflation != 1.0:
            mean = X.mean(axis=0)
            mean[PSI] = circular_mean(X[:, PSI])
            dev = X - mean
            dev[:, PSI] = wrap_pi(dev[:, PSI])
            X = mean + self.inflation * dev
            X[:, PSI] = wrap_2pi(X[:, PSI])
        self.X = X
        return Innovation(y, S, nis, rc, True)

    def shift(self, dn: float, de: float) -> None:
        """The plane's origin moved by (dn, de) m: positions follow, nothing else."""
        self.model.shift(self.X, dn, de)

    def reset_position(self, z: np.ndarray, R: np.ndarray) -> None:
        """Position from a fix alone (a GNSS jump): members drawn about it with R."""
        self.X[:, 0:2] = z + self.rng.multivariate_normal(np.zeros(2), R, size=len(self.X), method="cholesky")

    def ensemble_size(self) -> int:
        return len(self.X)
