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

from typing import ClassVar

import numpy as np

from edged.angles import wrap_2pi

from .cmm import Cmm
from .ctra import Ctra
from .filter import KalmanFilter
from .model import KINDS, PSI, Innovation, _eye, inv_small, judge, reset_position, residual, transition


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
        x, P = self.x, self.P
        H = self.model.H(kind, x)
        y = residual(k, z, self.model.h(kind, x))
        PHt = P @ H.T
        S = H @ PHt + R
        nis, rc, apply = judge(y, S, gate)
        if not apply:
            return Innovation(y, S, nis, rc, False)
        K = PHt @ inv_small(S)
        x = x + K @ y
        x[PSI] = wrap_2pi(x[PSI])
        IKH = _eye(len(x)) - K @ H
        P = IKH @ P @ IKH.T + K @ R @ K.T  # Joseph form: stays symmetric positive
        self.x, self.P = x, 0.5 * (P + P.T)
        return Innovation(y, S, nis, rc, True)

    def shift(self, dn: float, de: float) -> None:
        """The plane's origin moved by (dn, de) m: positions follow, nothing else."""
        self.model.shift(self.x, dn, de)

    def reset_position(self, z: np.ndarray, R: np.ndarray) -> None:
        """Position from a fix alone (a GNSS jump): its covariance R, no correlations."""
        reset_position(self.x, self.P, z, R)

    def ensemble_size(self) -> int:
        return 0
