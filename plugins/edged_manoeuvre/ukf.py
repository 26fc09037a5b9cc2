"""Unscented Kalman filter (seed 002 §3, Fig. 4): filterpy's, angle-aware.

filterpy's `UnscentedKalmanFilter` with Van der Merwe's scaled sigma points (seed 002
Table 3: λ = 1.72, i.e. α = 1, κ = λ, β = 2). What makes it safe across north:
- the state's residual wraps Δψ to (−π, π] (`residual_x`, also the sigma points'
  `subtract`), and the state's mean takes ψ as a circular mean of the sigma points
  (`x_mean_fn`): sigma points at 359.9° and 0.1° average to 0°, not 180°;
- for a heading measurement, the predicted measurement is a circular mean too
  (`z_mean_fn`) and its residual is wrapped (`residual_z`), set per sensor;
- ψ is put back in [0, 2π) after every step.
Each sigma point is propagated by the model's Runge–Kutta (all at once: the models
work on arrays of states). Before each update the sigma points are drawn afresh from
(x, P), so that two sensors at the same instant see the first one's update.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter, unscented_transform

from edged.angles import wrap_2pi, wrap_pi

from .cmm import Cmm
from .ctra import Ctra
from .filter import KalmanFilter
from .model import KINDS, PSI, Innovation, circular_mean, judge, reset_position, residual, rk4


def residual_x(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = np.subtract(a, b)
    d[..., PSI] = wrap_pi(d[..., PSI])
    return d


def x_mean(sigmas: np.ndarray, Wm: np.ndarray) -> np.ndarray:
    x = Wm @ sigmas
    x[PSI] = circular_mean(sigmas[:, PSI], Wm)
    return x


class _Ukf(UnscentedKalmanFilter):
    """filterpy's UKF whose sigma points go through f all at once."""

    def compute_process_sigmas(self, dt, fx=None, **fx_args):  # noqa: ANN001 (filterpy's signature)
        sigmas = self.points_fn.sigma_points(self.x, self.P)
        self.sigmas_f = self.fx(sigmas, dt) if dt > 0 else sigmas.copy()


class Ukf(KalmanFilter):
    name: ClassVar[str] = "ukf"

    def __init__(self, model: Ctra | Cmm, x0: np.ndarray, P0: np.ndarray, substep: float, lam: float = 1.72) -> None:
        self.model = model
        n = model.n
        points = MerweScaledSigmaPoints(n, alpha=1.0, beta=2.0, kappa=lam, subtract=residual_x)
        self._kf = _Ukf(dim_x=n, dim_z=1, dt=0.1, hx=None, fx=lambda s, dt: rk4(model.f, s, dt, substep),
                        points=points, x_mean_fn=x_mean, residual_x=residual_x)
        self._kf.x = np.array(x0, dtype=float)
        self._kf.P = np.array(P0, dtype=float)

    @property
    def x(self) -> np.ndarray:
        return self._kf.x

    @x.setter
    def x(self, v: np.ndarray) -> None:
        self._kf.x = v

    @property
    def P(self) -> np.ndarray:
        return self._kf.P

    @P.setter
    def P(self, v: np.ndarray) -> None:
        self._kf.P = v

    def predict(self, dt: float, Qc: np.ndarray) -> None:
        if dt <= 0.0:
            return
        self._kf.Q = Qc * dt
        self._kf.predict(dt=dt)
        self._kf.x[PSI] = wrap_2pi(self._kf.x[PSI])

    def update(self, kind: str, z: np.ndarray, R: np.ndarray, gate: float | None = None) -> Innovation:
        kf = self._kf
        k = KINDS[kind]
        kf.sigmas_f = kf.points_fn.sigma_points(kf.x, kf.P)  # (x, P) as they are now

        def z_mean(sig: np.ndarray, Wm: np.ndarray) -> np.ndarray:
            zm = Wm @ sig
            for i in k.angle_rows:
                zm[i] = circular_mean(sig[:, i], Wm)
            return zm

        def res_z(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            return residual(k, a, b)

        kf.z_mean, kf.residual_z = z_mean, res_z
        sig_h = self.model.h(kind, kf.sigmas_f)
        zp, S = unscented_transform(sig_h, kf.Wm, kf.Wc, R, z_mean, res_z)
        y = res_z(np.asarray(z, dtype=float), zp)
        nis, rc, apply = judge(y, S, gate)
        if not apply:
            return Innovation(y, S, nis, rc, False)
        kf._dim_z = k.dim
        kf.update(np.asarray(z, dtype=float), R=R, hx=lambda s: self.model.h(kind, s))
        kf.x[PSI] = wrap_2pi(kf.x[PSI])
        kf.P = 0.5 * (kf.P + kf.P.T)
        return Innovation(y, S, nis, rc, True)

    def shift(self, dn: float, de: float) -> None:
        """The plane's origin moved by (dn, de) m: positions follow, nothing else."""
        self.model.shift(self._kf.x, dn, de)

    def reset_position(self, z: np.ndarray, R: np.ndarray) -> None:
        """Position from a fix alone (a GNSS jump): its covariance R, no correlations."""
        reset_position(self._kf.x, self._kf.P, z, R)

    def ensemble_size(self) -> int:
        return 0
