"""Continuous-discrete extended Kalman filter (seed 002 §3, Fig. 3).

Predict (from the last time to the measurement's own time, any interval):
    x⁻ = x + ∫ f(x) dt              Runge–Kutta in sub-steps (model.transition)
    P⁻ = Φ P Φᵀ + Q_c·Δt            Φ the linearised model's transition over the same
                                     sub-steps; Q_c the continuous-time noise density
Update with one sensor's rows (the analytic Jacobian H of the model):
    y = z − h(x⁻)   (angle rows wrapped to (−π, π])
    S = H P⁻ Hᵀ + R,  NIS = yᵀ S⁻¹ y  (eq. 25),  rcond(S)  (eq. 23)
    K = P⁻ Hᵀ S⁻¹,  x = x⁻ + K y,  P = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ   (Joseph form)
ψ is then put back in [0, 2π). A measurement whose NIS exceeds `gate` is not applied
(the caller counts it).

The update is written out here rather than calling filterpy's `kalman.update`: at the
reference suite's ~160 updates/s of 1- and 2-row measurements filterpy's took 45 % of
the filter's time (`tests/bench/bench_manoeuvre.py`); this one reuses S from the NIS
and the gate and inverts it in closed form. `test_ekf_update_agrees_with_filterpy`
holds the two to 1e-12.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from edged.angles import wrap_2pi, wrap_pi

from .cmm import Cmm
from .ctra import Ctra
from .filter import KalmanFilter
from .model import KINDS, PSI, STATE_ROWS, Innovation, Kind, _eye, judge_inv, reset_position, residual, transition


class Ekf(KalmanFilter):
    name: ClassVar[str] = "ekf"

    def __init__(self, model: Ctra | Cmm, x0: np.ndarray, P0: np.ndarray, substep: float) -> None:
        self.model = model
        self.x = np.array(x0, dtype=float)
        self.P = np.array(P0, dtype=float)
        self.substep = substep

    def predict(self, dt: float, Qc: np.ndarray) -> None:
        if dt <= 0.0:
            return
        self.x, phi = transition(self.model.F, self.model.f, self.x, dt, self.substep)
        self.x[PSI] = wrap_2pi(self.x[PSI])
        self.P = phi @ self.P @ phi.T + Qc * dt

    def update(self, kind: str, z: np.ndarray, R: np.ndarray, gate: float | None = None) -> Innovation:
        k = KINDS[kind]
        rows = STATE_ROWS.get(kind)
        if rows is None:
            return self._update(k, z, R, gate)
        if len(rows) == 1:
            return self._update_scalar(k, rows[0], z, R, gate)
        return self._update_states(k, rows[0], rows[-1] + 1, z, R, gate)

    def _update(self, k: Kind, z: np.ndarray, R: np.ndarray, gate: float | None) -> Innovation:
        """The update as written in the module's docstring, for any rows of h."""
        x, P = self.x, self.P
        H = self.model.H(k.name, x)
        y = residual(k, z, self.model.h(k.name, x))
        PHt = P @ H.T
        S = H @ PHt + R
        nis, rc, apply, Si = judge_inv(y, S, gate)
        if not apply:
            return Innovation(y, S, nis, rc, False)
        K = PHt @ Si
        IKH = _eye(len(x)) - K @ H
        return self._apply(x + K @ y, IKH, K, R, Innovation(y, S, nis, rc, True))

    def _update_states(self, k: Kind, a: int, b: int, z: np.ndarray, R: np.ndarray,
                       gate: float | None) -> Innovation:
        """A sensor that reads states a..b−1 themselves (a position fix): H is rows of
        the identity, so P Hᵀ is P's columns, H P Hᵀ its block and K H the gain put in
        those columns; the same numbers as the products, without them."""
        x, P = self.x, self.P
        y = residual(k, z, x[a:b])
        PHt = P[:, a:b].copy()
        S = PHt[a:b] + R
        nis, rc, apply, Si = judge_inv(y, S, gate)
        if not apply:
            return Innovation(y, S, nis, rc, False)
        K = PHt @ Si
        IKH = _eye(len(x)).copy()
        IKH[:, a:b] -= K
        return self._apply(x + K @ y, IKH, K, R, Innovation(y, S, nis, rc, True))

    def _update_scalar(self, k: Kind, j: int, z: np.ndarray, R: np.ndarray, gate: float | None) -> Innovation:
        """A sensor of one row that reads state j (a heading, a yaw rate), as scalars:
        y = z − x_j (wrapped for an angle), S = P_jj + R (rcond 1 when positive and
        finite), NIS = y²/S, K = P_·j / S."""
        x, P = self.x, self.P
        y0 = float(z[0]) - float(x[j])
        if k.angle_rows:
            y0 = wrap_pi(y0)
        s = float(P[j, j]) + float(R[0, 0])
        y, S = np.array([y0]), np.array([[s]])
        if not (math.isfinite(s) and s > 0.0):
            return Innovation(y, S, math.inf, 0.0, False)
        inv = 1.0 / s
        nis = y0 * inv * y0
        if not (gate is None or nis <= gate):
            return Innovation(y, S, nis, 1.0, False)
        K = P[:, j] * inv
        IKH = _eye(len(x)).copy()
        IKH[:, j] -= K
        return self._apply(x + K * y0, IKH, K.reshape(-1, 1), R, Innovation(y, S, nis, 1.0, True))

    def _apply(self, x: np.ndarray, IKH: np.ndarray, K: np.ndarray, R: np.ndarray, inn: Innovation) -> Innovation:
        """x⁺ (ψ wrapped) and P⁺ = (I − K H) P⁻ (I − K H)ᵀ + K R Kᵀ (Joseph form: stays
        symmetric positive)."""
        x[PSI] = wrap_2pi(x[PSI])
        P = IKH @ self.P @ IKH.T + K @ R @ K.T
        self.x, self.P = x, 0.5 * (P + P.T)
        return inn

    def shift(self, dn: float, de: float) -> None:
        """The plane's origin moved by (dn, de) m: positions follow, nothing else."""
        self.model.shift(self.x, dn, de)

    def reset_position(self, z: np.ndarray, R: np.ndarray) -> None:
        """Position from a fix alone (a GNSS jump): its covariance R, no correlations."""
        reset_position(self.x, self.P, z, R)

    def ensemble_size(self) -> int:
        return 0
