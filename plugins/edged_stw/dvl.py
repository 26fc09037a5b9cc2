"""The log under test: the Doppler/EM log's offset and scale, fitted beside the filter.

    dvl = (1 + k)·u + b,   u = (v_g − c)·x̂     (x̂: ahead; v_g: filtered ground velocity)
fitted centred on a reference speed (g₀: the along-ship ground speed when the fit
starts) and linear in the state:
    dvl = (v_g − c)·x̂ + b₀ + k·(v_g·x̂ − g₀),   b₀ = b + k·u₀
At a steady speed b and k cannot be told apart (only b + k·u is seen), and an extended
filter on (b, k), with k multiplying a state, wanders along that line; b₀ and k are
nearly independent, k is seen only when the speed changes, the model is linear (k
multiplies a measured speed, not the current: k·Δc is a few mm/s), and
b = b₀ − k·u₀ with its σ from their covariance.
State  q = [c_n, c_e, ċ_n, ċ_e, b, k]: its own copy of the current and its rate of
change, the log's offset b (m/s) and scale error k. The current varies smoothly
(an integrated random walk, like the STW filter's drifting and turning hypotheses):
    c(k+1) = c + T·ċ,  ċ(k+1) = ċ + w,   Q = q·[[T³/3, T²/2], [T²/2, T]] per axis
so that a tidal stream turning over hours is followed while a speed change over minutes
cannot be mistaken for the water changing (that is what separates k from c); it is
given the STW filter's `turning` hypothesis' noise (`current_fast_q`). Forecasts update
the current as in the STW filter; the log updates all six states with a linear Kalman
update (the scale multiplies the measured ground speed, see below).

Why a copy of the current: the STW filter's current must never see the log, but a fit
of b and k against a current that only forecasts move inherits each forecast's jump as a
step in `dvl − STW`, and the fit reads those steps, when they fall near a speed change,
as a scale error. Here the log may tell its own current how the water speed *varies*
(what a log is good at), while its *level* still comes from the forecasts alone: b is
known as well as the forecasts know the current, and its σ says so. Nothing of this
filter flows back into the STW estimate.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .gating import cap_variance
from .kalman import identity, innovation_rows, innovation_scalar, update_rows, update_scalar

C, RATE, B, K = slice(0, 2), slice(2, 4), 4, 5
_Q_B = 0.05**2 / 86_400.0  # the offset may move 5 cm/s in a day (fouling, a new transducer)
_Q_K = 0.01**2 / 86_400.0  # and the scale 1 % in a day


@functools.lru_cache(maxsize=256)
def _model(T: float, q: float, fit_scale: bool) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of the module's model for a step of T s (read-only; kept: the log's
    interval repeats)."""
    F = np.eye(6)
    F[0, 2] = F[1, 3] = T
    Q = np.zeros((6, 6))
    for i, j in ((0, 2), (1, 3)):
        Q[i, i] = q * T**3 / 3.0
        Q[i, j] = Q[j, i] = q * T * T / 2.0
        Q[j, j] = q * T
    Q[B, B] = _Q_B * T
    Q[K, K] = _Q_K * T if fit_scale else 0.0
    F.flags.writeable = False
    Q.flags.writeable = False
    return F, Q


class LogCalibration:
    u0: float | None

    def __init__(self, t: float, trend_q: float, rate_sigma: float, prior_sigma: float, sigma_max: float,
                 scale_prior: float, fit_scale: bool = True) -> None:
        self.t = t
        #: Without a scale fit k is held at 0 (variance 0): see StwConfig.dvl_fit_scale.
        self.fit_scale = fit_scale
        scale_prior = scale_prior if fit_scale else 0.0
        self.q = trend_q
        self.rate_sigma = rate_sigma
        self.sigma_max = sigma_max
        self.x = np.zeros(6)
        self.P = np.diag([prior_sigma**2] * 2 + [rate_sigma**2] * 2 + [1.0, scale_prior**2])
        self.updates = 0
        self.u0 = None
        self.g0 = 0.0

    def predict(self, t: float) -> None:
        T = t - self.t
        if T <= 0.0:
            return
        F, Q = _model(T, self.q, self.fit_scale)
        self.x = np.dot(F, self.x)
        self.P = np.dot(np.dot(F, self.P), F.T) + Q
        self.P = cap_variance(self.P, C, self.sigma_max**2)
        self.P = cap_variance(self.P, RATE, (5.0 * self.rate_sigma) ** 2)
        self.t = t

    def forecast(self, t: float, c_n: float, c_e: float, var: float) -> None:
        self.predict(t)
        R = identity(2) * var
        y, S, _ = innovation_rows(self.x, self.P, np.array([c_n, c_e]), R, C)
        self.x, self.P = update_rows(self.x, self.P, y, S, R, C)

    def reading(self, t: float, z: float, ahead: np.ndarray, v_g: np.ndarray, var: float, gate: float,
                dry: bool = False) -> tuple[float, bool]:
        """One log reading along the ship; `var` includes the ground velocity's share.
        `dry`: the gate's verdict only (a log left out is still watched), no update."""
        self.predict(t)
        x = self.x
        g_along = float(v_g @ ahead)
        if self.u0 is None:
            self.g0 = g_along
            self.u0 = g_along - float(x[C] @ ahead)
        h = np.zeros(6)
        h[C] = -ahead
        h[B] = 1.0  # b₀
        h[K] = g_along - self.g0
        zl = z - g_along  # dvl − v_g·x̂ = −c·x̂ + b₀ + k·(v_g·x̂ − g₀)
        y, s, nis = innovation_scalar(x, self.P, zl, var, h)
        if not math.isfinite(nis) or nis > gate:
            return nis, False
        if dry:
            return nis, True
        self.x, self.P = update_scalar(x, self.P, y, s, var, h)
        self.updates += 1
        return nis, True

    def values(self) -> dict:
        if not self.updates or self.u0 is None:
            return {}
        u0, P = self.u0, self.P
        b = float(self.x[B] - self.x[K] * u0)
        var_b = P[B, B] + u0 * u0 * P[K, K] - 2.0 * u0 * P[B, K]
        return {
            "dvl_bias": b,
            "dvl_scale": 1.0 + float(self.x[K]) if self.fit_scale else None,
            "dvl_std": {
                "bias": math.sqrt(max(var_b, 0.0)),
                "scale": math.sqrt(max(P[K, K], 0.0)) if self.fit_scale else None,
            },
        }
