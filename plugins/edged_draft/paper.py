"""Seed 003's three-state filter for one draft mark, eqs. (12)–(24).

State x = [x_s, x_v, x_m]: the draft (m), its rate (m/s) and the amplitude of the
wave-induced oscillation (m) at the encounter frequency ω_e with phase ε, both given.

    A(t) = [[0, 1, ω_e cos(ω_e t + ε)], [0, 0, 0], [0, 0, 0]]     eq. (16), with the 1 of
                                                                 eq. (19)'s dt in it
    A(dt) = I + A(t)·dt  (A² = 0: exact)                         eq. (19)
    C = [1, 0, 0],  y = C x                                      eqs. (21), (22)
    Q = diag(0, q_v, q_m)                                        eq. (17)
    Q(dt) = ∫₀^dt A(τ) Q A(τ)ᵀ dτ with A(τ) = I + A τ:           eq. (23)
        [[(q_v + q_m c²) dt³/3,  q_v dt²/2,  q_m c dt²/2],
         [q_v dt²/2,             q_v dt,     0          ],
         [q_m c dt²/2,           0,          q_m dt     ]],  c = ω_e cos(ω_e t + ε)

Eq. (24) as printed integrates from the absolute time t to t + dt, so that Q grows with
t² and the filter, after an hour, trusts no reading (ESTIMATORS.md §3); here τ runs over
the step itself, the coefficient c taken at the step's start. t is measured from the
mark's first reading (the paper's simulations start at 0).

x_s holds the oscillation: it integrates x_m ω_e cos(ω_e t + ε), so the wave-free draft
under it is x_s − x_m sin(ω_e t + ε).
"""

from __future__ import annotations

import math

import numpy as np


class PaperMark:
    def __init__(self, z0: float, t0: float, omega: float, epsilon: float, q_v: float, q_m: float,
                 sigma: float) -> None:
        self.omega, self.eps, self.q_v, self.q_m = omega, epsilon, q_v, q_m
        self.t0 = t0
        self.t = t0
        self.x = np.array([z0, 0.0, 0.0])
        # P0: the first reading's variance; rate and amplitude unknown to a metre
        self.P = np.diag([sigma * sigma, 1.0, 1.0])

    def _phase(self, t: float) -> float:
        return self.omega * (t - self.t0) + self.eps

    def predict(self, t: float) -> None:
        dt = t - self.t
        if dt <= 0.0:
            return
        c = self.omega * math.cos(self._phase(self.t))
        A = np.array([[1.0, dt, c * dt], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # eq. (19)
        qv, qm = self.q_v, self.q_m
        Q = np.array([[(qv + qm * c * c) * dt**3 / 3.0, qv * dt * dt / 2.0, qm * c * dt * dt / 2.0],
                      [qv * dt * dt / 2.0, qv * dt, 0.0],
                      [qm * c * dt * dt / 2.0, 0.0, qm * dt]])  # eq. (23), τ over the step
        self.x = A @ self.x
        self.P = A @ self.P @ A.T + Q
        self.t = t

    def update(self, z: float, R: float, gate: float | None) -> tuple[float, float, float, bool]:
        """(y, S, NIS, applied) of one reading; not applied beyond the gate."""
        P = self.P
        y = z - self.x[0]  # eq. (21), C = [1, 0, 0]
        S = P[0, 0] + R
        nis = y * y / S
        if gate is not None and nis > gate:
            return y, S, nis, False
        K = P[:, 0] / S
        self.x = self.x + K * y
        self.P = P - np.outer(K, P[0, :])
        self.P = 0.5 * (self.P + self.P.T)
        return y, S, nis, True

    # -- what is published -----------------------------------------------------------
    @property
    def draft(self) -> float:
        return float(self.x[0])

    @property
    def draft_var(self) -> float:
        return float(self.P[0, 0])

    @property
    def mean(self) -> float:
        return float(self.x[0] - self.x[2] * math.sin(self._phase(self.t)))

    @property
    def mean_var(self) -> float:
        s = math.sin(self._phase(self.t))
        P = self.P
        return float(P[0, 0] - 2.0 * s * P[0, 2] + s * s * P[2, 2])

    @property
    def rate(self) -> float:
        return float(self.x[1])

    @property
    def rate_var(self) -> float:
        return float(self.P[1, 1])

    @property
    def amplitude(self) -> float:
        return abs(float(self.x[2]))
