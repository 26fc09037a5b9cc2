"""The shared part of every draft mark's wave model (`waves.py` has its equations):
the resonators' frequencies and how they follow the sea, H, F(dt) and Q(dt) per step
size, and every mark's state stacked one row each, so that a reading of each of six
marks is one numpy call, not six (`waves.step_marks`)."""

from __future__ import annotations

import math

import numpy as np


class WaveBank:
    """The shared parts of every mark's model: frequencies, H, F and Q per step size."""

    #: The first resonator's row of the state (d, ḋ, d̈, κ before it).
    W0 = 4

    def __init__(self, period_min: float, period_max: float, k: int, damping: float, q_jerk: float,
                 q_squat: float = 0.0) -> None:
        w_hi, w_lo = 2.0 * math.pi / period_min, 2.0 * math.pi / period_max
        self.omega0 = np.exp(np.linspace(math.log(w_lo), math.log(w_hi), k)) if k > 1 else np.array([w_lo])
        self.omega = self.omega0.copy()
        # each resonator keeps to its own band (half-way to its neighbours, in log ω)
        step = math.log(w_hi / w_lo) / (k - 1) if k > 1 else 0.1
        self.omega_lo, self.omega_hi = self.omega0 * math.exp(-0.5 * step), self.omega0 * math.exp(0.5 * step)
        self._err = np.zeros(k)  # Σ energy × (phase rate − ω) since the last retune
        self._wsum = np.zeros(k)
        self.k = k
        self.zeta = damping
        self.q_jerk = q_jerk
        self.q_squat = q_squat
        w0 = self.W0
        self.n = w0 + 2 * k
        H = np.zeros(self.n)
        H[0] = 1.0
        H[w0::2] = 1.0
        self.H = H
        self.idx = np.flatnonzero(H)
        # the resonators' diagonal in a flattened P: a strided slice (a view, not a gather)
        self.wave_diag = slice(w0 * (self.n + 1), None, self.n + 1)
        self._cache: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._rot: dict[float, tuple[np.ndarray, np.ndarray]] = {}  # see rotation()
        # every mark's state, one row each (`WaveMark.row`): stacked, so that a reading
        # from each of six marks is one numpy call, not six (`step_marks`)
        self.X = np.zeros((0, self.n))
        self.P = np.zeros((0, self.n, self.n))
        self.var_k = np.zeros((0, k))  # each resonator's σ_k² (`sample`)
        self.var2 = np.zeros((0, 2 * k))  # the same per state (c_k, s_k), for Q
        self.prev_c = np.zeros((0, k))  # the resonators at each mark's last update
        self.prev_s = np.zeros((0, k))
        self.prev_t = np.zeros(0)  # its time (NaN: none yet)

    @property
    def rows(self) -> int:
        return len(self.X)

    def new_row(self) -> int:
        """A row for one more mark's state."""
        r = self.rows
        self.X = np.concatenate([self.X, np.zeros((1, self.n))])
        self.P = np.concatenate([self.P, np.zeros((1, self.n, self.n))])
        self.var_k = np.concatenate([self.var_k, np.zeros((1, self.k))])
        self.var2 = np.concatenate([self.var2, np.zeros((1, 2 * self.k))])
        self.prev_c = np.concatenate([self.prev_c, np.zeros((1, self.k))])
        self.prev_s = np.concatenate([self.prev_s, np.zeros((1, self.k))])
        self.prev_t = np.concatenate([self.prev_t, [math.nan]])
        return r

    def transition(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """F(dt), the unit-variance part of the resonators' Q (1 − e^(−2ζω dt)) and the
        level's and κ's Q (4 × 4), made once per step size (the sensors keep to their
        rate)."""
        key = round(dt, 6)
        got = self._cache.get(key)
        if got is not None:
            return got
        F = np.zeros((self.n, self.n))
        F[0, 0] = F[1, 1] = F[2, 2] = F[3, 3] = 1.0
        F[0, 1] = F[1, 2] = dt
        F[0, 2] = 0.5 * dt * dt
        decay = np.exp(-self.zeta * self.omega * dt)
        for i, (w, a) in enumerate(zip(self.omega, decay)):
            j = self.W0 + 2 * i
            c, s = a * math.cos(w * dt), a * math.sin(w * dt)
            F[j, j], F[j, j + 1], F[j + 1, j], F[j + 1, j + 1] = c, -s, s, c
        unit = 1.0 - np.exp(-2.0 * self.zeta * self.omega * dt)
        if len(self._cache) > 64:
            self._cache.clear()
        level_q = np.zeros((4, 4))
        level_q[:3, :3] = self.level_q(dt)
        level_q[3, 3] = self.q_squat * dt
        got = self._cache[key] = (F, np.repeat(unit, 2), level_q)
        return got

    def rotation(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Each resonator's a cos(ω dt) and a sin(ω dt), as in F(dt): the compiled
        predict's view of F (`kernel.predict_marks`)."""
        key = round(dt, 6)
        got = self._rot.get(key)
        if got is None:
            F = self.transition(dt)[0]
            w0 = self.W0
            idx = np.arange(w0, self.n, 2)
            if len(self._rot) > 64:
                self._rot.clear()
            got = self._rot[key] = (F[idx, idx].copy(), F[idx + 1, idx].copy())
        return got

    def observe_phase(self, energy: np.ndarray, rate_error: np.ndarray) -> None:
        """A mark's resonators turned at ω + rate_error (rad/s) with this energy (or
        several marks', one row each)."""
        if energy.ndim == 1:
            self._err += energy * rate_error
            self._wsum += energy
        else:
            self._err += (energy * rate_error).sum(axis=0)
            self._wsum += energy.sum(axis=0)

    def retune(self, gain: float) -> None:
        """Move each ω toward the phase rate its resonators showed, energy-weighted
        over all marks (one sea under all of them), by `gain` of the difference."""
        ok = self._wsum > 0.0
        if not np.any(ok):
            return
        d = np.where(ok, self._err / np.where(ok, self._wsum, 1.0), 0.0)
        self.omega = np.clip(self.omega + gain * d, self.omega_lo, self.omega_hi)
        self._err[:] = 0.0
        self._wsum[:] = 0.0
        self._cache.clear()
        self._rot.clear()

    def level_q(self, dt: float) -> np.ndarray:
        q = self.q_jerk
        d2, d3, d4, d5 = dt * dt, dt**3, dt**4, dt**5
        return q * np.array([[d5 / 20.0, d4 / 8.0, d3 / 6.0], [d4 / 8.0, d3 / 3.0, d2 / 2.0], [d3 / 6.0, d2 / 2.0, dt]])
