"""The sea current and the sway through the water: an IMM filter of three hypotheses.

State (local plane, north/east):
    y = [c_n, c_e, ċ_n, ċ_e, s, k]
    c: current (velocity of the water over ground), ċ: its rate of change, s: sway of
    the hull through the water (leeway), k: the sway a rate of turn gives (m/rad): a
    turning hull pivots about a point ahead of the reference point, which then slides
    outwards at v = k·r, k ≈ −x_pivot (a 300 m tanker turning at 0.2°/s sways 0.4 m/s
    through the water for as long as she turns; read as current, that is 0.4 m/s of
    current across, and after her next 90° turn along, the ship).

No single random-walk σ_c suits both a steady following current and a rotating cross
current (ESTIMATORS.md §1), so three hypotheses run side by side and are mixed by how
well each predicts what is seen (interacting multiple models, Blom & Bar-Shalom 1988):
    steady:   c(k+1) = c + w_c,        Q_c = q_s·T·I,    ċ ≡ 0
    drifting: c(k+1) = c + T·ċ,  ċ(k+1) = ċ + w_ċ,   Q = q·[[T³/3, T²/2], [T²/2, T]] per axis,
              with q = q_slow (a current that changes over many hours)
    turning:  the same with q = q_fast (a tidal stream that turns within the hour)
In the drifting and turning hypotheses the current keeps its speed as it turns (a
pseudo-measurement ĉ·ċ = 0 after each update, `_keep_speed`). Mixing (each hypothesis
switching to another with probability `switch`) happens at each forecast, the only
moment the along-track current is observed; the mode probabilities
move with the forecast and the heading-course likelihoods.
    s(k+1) = φ·s + w_s,  φ = exp(−T/τ_s),  Q_s = σ_s²(1 − φ²)   (leeway persists for τ_s)
    k(k+1) = k + w_k,    Q_k = q_k·T           (a property of the hull and its loading)

Measurements:
    forecast            z = [c_n, c_e]                     R = σ_f²·I
    heading vs course   z = v_g·ŷ = c·ŷ + s + k·r          (ŷ: the ship's starboard axis, r the
                        gyro's rate of turn; the hull's velocity through the water is
                        along the ship but for its sway; k is seen when r changes)
                        a Schmidt update: the current along the ship (c·x̂, ċ·x̂) is held,
                        only the part across the ship and s move (`gating.consider_update`)
The Doppler log is not a measurement of this filter (`dvl.py` fits it).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .gating import cap_variance, consider_update
from .kalman import identity, innovation, innovation_rows, innovation_scalar, update, update_scalar

C, RATE, S, K = slice(0, 2), slice(2, 4), 4, 5
N_STATE = 6
#: Prior σ of k (m/rad): the pivot point of a 300 m ship lies up to ~100 m ahead of
#: midships; a yacht's, a few metres.
K_SIGMA = 150.0
#: How fast a current's speed may change (m/s²): 1 m/s in an hour (a tidal stream from
#: slack water to 3 kn in three hours changes by 0.5 m/s an hour).
SPEED_RATE_SIGMA = 1.0 / 3600.0
#: k's random walk (m²/rad²/s): 10 m an hour (loading, speed, depth change it slowly).
Q_K = 10.0**2 / 3600.0
_H_FORECAST = np.eye(N_STATE)[C]


@dataclass(frozen=True)
class CurrentParams:
    q_steady: float
    q_slow: float
    q_fast: float
    rate_sigma: float
    switch: float
    prior_sigma: float
    sigma_max: float
    leeway_sigma: float
    leeway_time: float

    def modes(self) -> tuple[tuple[str, float | None], ...]:
        """(name, q of the rate) per hypothesis; None: no rate (steady)."""
        return (("steady", None), ("drifting", self.q_slow), ("turning", self.q_fast))


@functools.lru_cache(maxsize=512)
def _transition(T: float, q_rate: float | None, q_scale: float, sway_sigma: float, q_steady: float,
                leeway_time: float) -> tuple[np.ndarray, np.ndarray]:
    """F and Q of one hypothesis for a step of T s (the module's model; read-only,
    kept: a tick, a log reading and a look of heading − course predict all three
    hypotheses over the same intervals; the key is floats, which hash fast)."""
    F = np.eye(N_STATE)
    Q = np.zeros((N_STATE, N_STATE))
    if q_rate is not None:
        q = q_rate * q_scale
        F[0, 2] = F[1, 3] = T
        for i, j in ((0, 2), (1, 3)):
            Q[i, i] = q * T**3 / 3.0
            Q[i, j] = Q[j, i] = q * T * T / 2.0
            Q[j, j] = q * T
    else:
        F[2, 2] = F[3, 3] = 0.0
        Q[0, 0] = Q[1, 1] = q_steady * q_scale * T
    phi = math.exp(-T / leeway_time)
    F[S, S] = phi
    Q[S, S] = sway_sigma**2 * (1.0 - phi * phi)
    Q[K, K] = Q_K * T
    F.flags.writeable = False
    Q.flags.writeable = False
    return F, Q


class CurrentFilter:
    """One Kalman filter per current hypothesis, on the same state."""

    def __init__(self, t: float, p: CurrentParams) -> None:
        self.t = t
        self.p = p
        self.modes = p.modes()
        n = len(self.modes)
        P = np.diag([p.prior_sigma**2] * 2 + [p.rate_sigma**2] * 2 + [p.leeway_sigma**2, K_SIGMA**2])
        self.y = [np.zeros(N_STATE) for _ in range(n)]
        self.P = [self._pin(P.copy()) if q is None else P.copy() for _, q in self.modes]
        self.mu = np.full(n, 1.0 / n)
        #: Scale of every hypothesis' process noise, adapted from the forecast
        #: innovations (`adapt`): 1 while forecasts land where predicted.
        self.q_scale = 1.0
        #: Stationary 1-σ of the sway state (leeway and compass misalignment; the
        #: vector model sets it from the speed).
        self.sway_sigma = p.leeway_sigma
        self.Pi = np.full((n, n), p.switch / (n - 1))
        np.fill_diagonal(self.Pi, 1.0 - p.switch)

    @staticmethod
    def _pin(P: np.ndarray) -> np.ndarray:
        """The steady hypothesis has no rate of change: its rate states are exactly 0."""
        P[RATE, :] = 0.0
        P[:, RATE] = 0.0
        return P

    def _predict_one(self, y: np.ndarray, P: np.ndarray, T: float, q_rate: float | None) -> tuple[np.ndarray, np.ndarray]:
        p = self.p
        F, Q = _transition(T, q_rate, self.q_scale, self.sway_sigma, p.q_steady, p.leeway_time)
        y = np.dot(F, y)
        P = np.dot(np.dot(F, P), F.T) + Q
        P = cap_variance(P, C, self.p.sigma_max**2)
        if q_rate is not None:
            P = cap_variance(P, RATE, (5.0 * self.p.rate_sigma) ** 2)
        return y, P

    def predict(self, t: float) -> None:
        T = t - self.t
        if T <= 0.0:
            return
        for m, (_, q) in enumerate(self.modes):
            self.y[m], self.P[m] = self._predict_one(self.y[m], self.P[m], T, q)
        self.t = t

    def mixture(self, t: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The combined estimate (mean and covariance, spread of the hypotheses
        included), predicted to t when given without changing the filter."""
        ys, Ps = self.y, self.P
        if t is not None and t > self.t:
            pairs = [self._predict_one(self.y[m], self.P[m], t - self.t, q) for m, (_, q) in enumerate(self.modes)]
            ys, Ps = [a for a, _ in pairs], [b for _, b in pairs]
        mu = self.mu.tolist()
        y = sum(mu[m] * ys[m] for m in range(len(ys)))
        P = np.zeros((N_STATE, N_STATE))
        for m in range(len(ys)):
            d = ys[m] - y
            P += mu[m] * (Ps[m] + d[:, None] * d[None, :])
        return y, P

    def _mix(self) -> None:
        """IMM interaction: each hypothesis starts from the others' estimates, weighted."""
        n = len(self.modes)
        c = self.Pi.T @ self.mu
        w = (self.Pi * self.mu[:, None]) / c[None, :]
        ys, Ps = [], []
        for j, (_, q) in enumerate(self.modes):
            y0 = sum(w[i, j] * self.y[i] for i in range(n))
            P0 = np.zeros((N_STATE, N_STATE))
            for i in range(n):
                d = self.y[i] - y0
                P0 += w[i, j] * (self.P[i] + np.outer(d, d))
            if q is None:
                y0[RATE] = 0.0
                P0 = self._pin(P0)
            ys.append(y0)
            Ps.append(P0)
        self.y, self.P = ys, Ps
        self.mu = c

    def _update_modes(self, z: np.ndarray, R: np.ndarray, H: np.ndarray, held: np.ndarray | None = None) -> None:
        like = np.zeros(len(self.modes))
        for m, (_, q) in enumerate(self.modes):
            y, S, nis = innovation(self.y[m], self.P[m], z, R, H)
            like[m] = math.exp(-0.5 * min(nis, 200.0)) / math.sqrt(max(np.linalg.det(S), 1e-300))
            if held is None:
                self.y[m], self.P[m] = update(self.y[m], self.P[m], y, S, R, H)
            else:
                self.y[m], self.P[m] = consider_update(self.y[m], self.P[m], z, R, H, held)
            if q is None:
                self.y[m][RATE] = 0.0
                self.P[m] = self._pin(self.P[m])
        total = float(self.mu @ like)
        if total > 0.0 and math.isfinite(total):
            mu = np.clip(self.mu * like / total, 1e-6, 1.0)
            self.mu = mu / mu.sum()

    def forecast_nis(self, t: float, c_n: float, c_e: float, var: float) -> float:
        """NIS of a forecast against the combined estimate at t (the gate's test)."""
        y, P = self.mixture(t)
        _, _, nis = innovation_rows(y, P, np.array([c_n, c_e]), identity(2) * var, C)
        return nis

    def forecast(self, t: float, c_n: float, c_e: float, var: float) -> None:
        self.predict(t)
        self._mix()
        self._update_modes(np.array([c_n, c_e]), identity(2) * var, _H_FORECAST)
        self._keep_speed()

    def _keep_speed(self) -> None:
        """A current that turns keeps its speed (a rotary tidal stream, an eddy): in the
        hypotheses with a rate, the rate along the current's own direction, d|c|/dt =
        ĉ·ċ, is observed as 0 within SPEED_RATE_SIGMA. What forecasts and heading −
        course say of the current's turning then stays a turning: noisy forecasts
        (σ 0.2 m/s every 20 minutes) do not make the current grow or fade at their
        trend's rate between them, which had taken a 1.0 m/s current to 2 m/s."""
        for m, (_, q) in enumerate(self.modes):
            if q is None:
                continue
            y, P = self.y[m], self.P[m]
            speed = math.hypot(y[0], y[1])
            if speed < 0.1:
                continue
            h = np.zeros(N_STATE)
            h[RATE] = y[C] / speed
            r = SPEED_RATE_SIGMA**2
            e, s, _ = innovation_scalar(y, P, 0.0, r, h)
            self.y[m], self.P[m] = update_scalar(y, P, e, s, r, h)

    def adapt(self, nis_history: list[float], limit: float) -> None:
        """Covariance matching on the forecasts: a forecast's NIS has mean 2 (2 dof)
        when the filter's current is as uncertain as it says. Recent forecasts landing
        further off mean the current changes faster than every hypothesis allows: all
        process noises are scaled by mean(NIS)/2, within [1, limit]."""
        if nis_history:
            self.q_scale = float(min(max(sum(nis_history) / len(nis_history) / 2.0, 1.0), limit))

    def inflate(self, sigma: float) -> None:
        """Forget what was known of the current (forecasts kept contradicting it)."""
        for P in self.P:
            P[C, :] = 0.0
            P[:, C] = 0.0
            P[C, C] = identity(2) * sigma * sigma

    def cross(self, t: float, z: float, starboard: np.ndarray, var: float, gate: float,
              r: float = 0.0) -> tuple[float, bool]:
        """Heading vs course: the ground velocity across the ship is current + sway, the
        sway being the leeway and the turn's k·r (r: rate of turn, rad/s)."""
        self.predict(t)
        H = np.zeros((1, N_STATE))
        H[0, C] = starboard
        H[0, S] = 1.0
        H[0, K] = r
        y, P = self.mixture()
        _, _, nis = innovation(y, P, np.array([z]), np.array([[var]]), H)
        if not nis <= gate:  # NaN fails too
            return nis, False
        # The look sees the current across the ship; along the ship (its complement) it
        # sees only the heading's wander times the speed, and the leeway changing with
        # the heading: that component and its rate are held (Schmidt update), so the
        # current along the ship comes from the forecasts alone (ESTIMATORS.md §1).
        ahead = np.array([starboard[1], -starboard[0]])  # x̂ = ŷ turned 90° to port
        held = np.zeros((N_STATE, 2))
        held[C, 0] = ahead
        held[RATE, 1] = ahead
        self._update_modes(np.array([z]), np.array([[var]]), H, held)
        self._keep_speed()
        return nis, True

    def mode_probabilities(self) -> dict[str, float]:
        return {name: float(p) for (name, _), p in zip(self.modes, self.mu)}
