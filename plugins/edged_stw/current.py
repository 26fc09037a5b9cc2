"""The sea current, the sway through the water and the log's error: an IMM filter.

State (local plane, north/east):
    y = [c_n, c_e, ċ_n, ċ_e, s]
    c: current (velocity of the water over ground), ċ: its rate of change, s: sway of
    the hull through the water (leeway).

Two hypotheses about the current (ESTIMATORS.md §1: no single random-walk σ_c suits
both a steady following current and a rotating cross current), mixed by how well each
predicts what is seen (interacting multiple models, Blom & Bar-Shalom 1988):
    steady:  c(k+1) = c + w_c,          Q_c = q_s·T·I,   ċ ≡ 0
    trend:   c(k+1) = c + T·ċ,  ċ(k+1) = ċ + w_ċ,   Q = q_t·[[T³/3, T²/2], [T²/2, T]] per axis
The mode probabilities move with the forecast and heading-course likelihoods; mixing
(with switch probability `p`) happens at each forecast, the only moment the along-track
current is observed.
    s(k+1) = φ·s + w_s,  φ = exp(−T/τ_s),  Q_s = σ_s²(1 − φ²)   (leeway persists for τ_s)

Measurements:
    forecast            z = [c_n, c_e]                     R = σ_f²·I
    heading vs course   z = v_g·ŷ = c·ŷ + s                (ŷ: the ship's starboard axis;
                        the hull's velocity through the water is along the ship but for s)
The Doppler log is not a measurement of this filter (`dvl.py` fits it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .gating import cap_variance, innovation, update

C, RATE, S = slice(0, 2), slice(2, 4), 4
N_STATE = 5
STEADY, TREND = 0, 1
MODES = ("steady", "trend")
_H_FORECAST = np.eye(N_STATE)[C]


@dataclass(frozen=True)
class CurrentParams:
    q_steady: float
    q_trend: float
    rate_sigma: float
    switch: float
    prior_sigma: float
    sigma_max: float
    leeway_sigma: float
    leeway_time: float


class CurrentFilter:
    """Two Kalman filters on the same state, one per current hypothesis."""

    def __init__(self, t: float, p: CurrentParams) -> None:
        self.t = t
        self.p = p
        y = np.zeros(N_STATE)
        P = np.diag([p.prior_sigma**2] * 2 + [p.rate_sigma**2] * 2 + [p.leeway_sigma**2])
        self.y = [y.copy(), y.copy()]
        self.P = [self._pin(P.copy()), P.copy()]
        self.mu = np.array([0.5, 0.5])
        self.Pi = np.array([[1.0 - p.switch, p.switch], [p.switch, 1.0 - p.switch]])

    @staticmethod
    def _pin(P: np.ndarray) -> np.ndarray:
        """The steady model has no rate of change: its rate states are exactly 0."""
        P[RATE, :] = 0.0
        P[:, RATE] = 0.0
        return P

    def _transition(self, T: float, mode: int) -> tuple[np.ndarray, np.ndarray]:
        p = self.p
        F = np.eye(N_STATE)
        Q = np.zeros((N_STATE, N_STATE))
        if mode == TREND:
            F[0, 2] = F[1, 3] = T
            for i, j in ((0, 2), (1, 3)):
                Q[i, i] = p.q_trend * T**3 / 3.0
                Q[i, j] = Q[j, i] = p.q_trend * T * T / 2.0
                Q[j, j] = p.q_trend * T
        else:
            F[2, 2] = F[3, 3] = 0.0
            Q[0, 0] = Q[1, 1] = p.q_steady * T
        phi = math.exp(-T / p.leeway_time)
        F[S, S] = phi
        Q[S, S] = p.leeway_sigma**2 * (1.0 - phi * phi)
        return F, Q

    def _predict_one(self, y: np.ndarray, P: np.ndarray, T: float, mode: int) -> tuple[np.ndarray, np.ndarray]:
        F, Q = self._transition(T, mode)
        y = F @ y
        P = F @ P @ F.T + Q
        P = cap_variance(P, C, self.p.sigma_max**2)
        if mode == TREND:
            P = cap_variance(P, RATE, (5.0 * self.p.rate_sigma) ** 2)
        return y, P

    def predict(self, t: float) -> None:
        T = t - self.t
        if T <= 0.0:
            return
        for m in (STEADY, TREND):
            self.y[m], self.P[m] = self._predict_one(self.y[m], self.P[m], T, m)
        self.t = t

    def mixture(self, t: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The combined estimate (mean and covariance, spread of the modes included),
        predicted to t when given without changing the filter."""
        ys, Ps = self.y, self.P
        if t is not None and t > self.t:
            pairs = [self._predict_one(self.y[m], self.P[m], t - self.t, m) for m in (STEADY, TREND)]
            ys, Ps = [a for a, _ in pairs], [b for _, b in pairs]
        y = self.mu[0] * ys[0] + self.mu[1] * ys[1]
        P = np.zeros((N_STATE, N_STATE))
        for m in (STEADY, TREND):
            d = ys[m] - y
            P += self.mu[m] * (Ps[m] + np.outer(d, d))
        return y, P

    def _mix(self) -> None:
        """IMM interaction: each model starts from the others' estimates, weighted."""
        c = self.Pi.T @ self.mu
        w = (self.Pi * self.mu[:, None]) / c[None, :]
        ys, Ps = [], []
        for j in (STEADY, TREND):
            y0 = w[0, j] * self.y[0] + w[1, j] * self.y[1]
            P0 = np.zeros((N_STATE, N_STATE))
            for i in (STEADY, TREND):
                d = self.y[i] - y0
                P0 += w[i, j] * (self.P[i] + np.outer(d, d))
            if j == STEADY:
                y0[RATE] = 0.0
                P0 = self._pin(P0)
            ys.append(y0)
            Ps.append(P0)
        self.y, self.P = ys, Ps
        self.mu = c

    def _update_modes(self, z: np.ndarray, R: np.ndarray, H_of: list[np.ndarray]) -> None:
        like = np.zeros(2)
        for m in (STEADY, TREND):
            H = H_of[m]
            y, S, nis = innovation(self.y[m], self.P[m], z, R, H)
            like[m] = math.exp(-0.5 * min(nis, 200.0)) / math.sqrt(max(np.linalg.det(S), 1e-300))
            self.y[m], self.P[m] = update(self.y[m], self.P[m], z, R, H)
            if m == STEADY:
                self.y[m][RATE] = 0.0
                self.P[m] = self._pin(self.P[m])
        total = float(self.mu @ like)
        if total > 0.0 and math.isfinite(total):
            self.mu = self.mu * like / total
            self.mu = np.clip(self.mu, 1e-6, 1.0)
            self.mu /= self.mu.sum()

    def forecast_nis(self, t: float, c_n: float, c_e: float, var: float) -> float:
        """NIS of a forecast against the combined estimate at t (the gate's test)."""
        y, P = self.mixture(t)
        _, _, nis = innovation(y, P, np.array([c_n, c_e]), np.eye(2) * var, _H_FORECAST)
        return nis

    def forecast(self, t: float, c_n: float, c_e: float, var: float) -> None:
        self.predict(t)
        self._mix()
        self._update_modes(np.array([c_n, c_e]), np.eye(2) * var, [_H_FORECAST, _H_FORECAST])

    def inflate(self, sigma: float) -> None:
        """Forget what was known of the current (forecasts kept contradicting it)."""
        for m in (STEADY, TREND):
            P = self.P[m]
            P[C, :] = 0.0
            P[:, C] = 0.0
            P[C, C] = np.eye(2) * sigma * sigma

    def cross(self, t: float, z: float, starboard: np.ndarray, var: float) -> float:
        """Heading vs course: the ground velocity across the ship is current + sway."""
        self.predict(t)
        H = np.zeros((1, N_STATE))
        H[0, C] = starboard
        H[0, S] = 1.0
        y, P = self.mixture()
        _, _, nis = innovation(y, P, np.array([z]), np.array([[var]]), H)
        self._update_modes(np.array([z]), np.array([[var]]), [H, H])
        return nis
