"""One draft mark in real seas: the wave-free level and the wave motion on top of it.

Why not the paper's model: it needs ω_e and ε, which a real sea does not announce, and
one sine, where a sea is a spectrum (the encounter frequency moves with speed and
heading too). Ship motion control has long filtered waves out of the low-frequency
motion with a linear wave model driven by white noise (Fossen and Perez, "Kalman
filtering for positioning and heading control of ships and offshore rigs", IEEE
Control Systems 29(6), 2009): a second-order resonator per frequency band. A bank of
them, log-spaced over the periods a ship meets, spans a spectrum; the filter shares the
motion out among them, and the sum is the wave-induced draft.

State x = [d, ḋ, d̈, κ, c_1, s_1, …, c_K, s_K]:

    level (the wave-free draft, with its rate and acceleration; cargo work and squat):
        ḋ = ḋ,  d(ḋ)/dt = d̈,  d(d̈)/dt = w_j,         E[w_j²] = q_j (jerk density)
        F = [[1, dt, dt²/2], [0, 1, dt], [0, 0, 1]]
        Q = q_j [[dt⁵/20, dt⁴/8, dt³/6], [dt⁴/8, dt³/3, dt²/2], [dt³/6, dt²/2, dt]]
    squat: the level sinks by κ·V² as the ship speeds up through the water (every
    squat formula, Barrass's, ICORELS, Huuska's, is C·V² times a depth factor), κ its
    coefficient for this ship in this water, learned, a slow random walk:
        d ← d + κ·Δu,  u = V² the STW squared (m²/s²), Δu its change over the step
        κ ← κ + w_κ,   E[w_κ²] = q_κ·dt
    A level alone cannot tell a squat ramp of a few cm/s from the slow end of the sea
    (tens of seconds either way); the speed can: it moves the level and not the waves.
    Without a speed, Δu = 0 and κ sleeps.
    resonator k (frequency ω_k, damping ratio ζ), a damped rotation:
        d/dt [c, s] = [[−ζω_k, −ω_k], [ω_k, −ζω_k]] [c, s] + w_k
        F_k = e^(−ζω_k dt) [[cos ω_k dt, −sin ω_k dt], [sin ω_k dt, cos ω_k dt]]
        Q_k = σ_k² (1 − e^(−2ζω_k dt)) I     (σ_k²: each component's stationary variance)
    reading:
        z = d + Σ_k c_k + v,   E[v²] = R      H = [1, 0, 0, 0, 1, 0, 1, 0, …]

Each resonator's σ_k is its share of the sea, learned: the mean of c_k² + s_k² over
`window` seconds, halved, never below `floor`. Resonators where the sea has no energy
then pass no sensor noise, and those at its peak follow it.

Published: the instantaneous draft Hx, the mean d, its rate ḋ, the amplitude √2 × the
RMS of the wave part Σ c_k over `amplitude_window` seconds (the amplitude of a sine).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .bank import WaveBank

#: Seconds between the samples of each resonator's energy and of the wave part's
#: square (`WaveMark._sample`): one reading in ten at 100 Hz, a tenth of the work.
#: (The phase advance the bank retunes from is read at every update: read over
#: 0.1 s, the 90-s mean errors of a regular sea doubled.)
SAMPLE_STEP = 0.1


class WaveMark:
    def __init__(self, bank: WaveBank, z0: float, t0: float, sigma: float, wave_sigma: float,
                 window: float = 120.0, floor: float = 0.005, amplitude_window: float = 60.0,
                 squat: tuple[float, float] = (0.0, 0.0), row: int | None = None) -> None:
        self.bank = bank
        n = bank.n
        self.row = bank.new_row() if row is None else row
        self.t = self.t0 = self._sampled = t0
        x = np.zeros(n)
        x[0] = z0
        P = np.zeros((n, n))
        P[0, 0] = sigma * sigma + wave_sigma * wave_sigma * bank.k  # the first reading holds a wave
        P[1, 1] = 1e-4  # 1 cm/s
        P[2, 2] = 1e-6
        x[3] = squat[0]  # κ's prior, m per (m/s)², and its 1-σ
        P[3, 3] = squat[1] * squat[1]
        w0 = bank.W0
        r = self.row
        bank.var_k[r] = wave_sigma * wave_sigma
        bank.var2[r] = np.repeat(bank.var_k[r], 2)
        P[w0:, w0:] = np.diag(bank.var2[r])
        bank.X[r], bank.P[r] = x, P
        bank.prev_t[r] = math.nan
        self.u: float | None = None  # V² at self.t, m²/s² (None: no speed)
        self.u_rate = 0.0
        self.window = window
        self.floor2 = floor * floor
        self.amp_window = amplitude_window
        self._wave2 = 0.0  # EWMA of the wave part squared
        self._wave_n = 0

    # this mark's row of the bank's stacked state (views: writing them writes the bank)
    @property
    def x(self) -> np.ndarray:
        return self.bank.X[self.row]

    @property
    def P(self) -> np.ndarray:
        return self.bank.P[self.row]

    @property
    def var_k(self) -> np.ndarray:
        """Each resonator's share of the sea here, σ_k² (m²)."""
        return self.bank.var_k[self.row]

    def predict(self, t: float, u: float | None = None, u_rate: float = 0.0) -> None:
        """To time t, where the STW squared is u (None: unknown) and changing at u_rate."""
        dt = t - self.t
        if dt <= 0.0:
            return
        b, r = self.bank, self.row
        F, unit, level_q = b.transition(dt)
        x = F @ b.X[r]
        P = F @ b.P[r] @ F.T
        P[:4, :4] += level_q
        P.reshape(-1)[b.wave_diag] += b.var2[r] * unit
        if u is not None and self.u is not None and u != self.u:
            # d ← d + Δu·κ: J = I + Δu e₀e₃ᵀ, P ← J P Jᵀ
            du = u - self.u
            x[0] += du * x[3]
            P[0, :] += du * P[3, :]
            P[:, 0] += du * P[:, 3]
        self.u, self.u_rate = u, (u_rate if u is not None else 0.0)
        b.X[r], b.P[r] = x, P
        self.t = t
        if t - self._sampled >= SAMPLE_STEP:
            self._sample(t - self._sampled, x)

    def _sample(self, dt: float, x: np.ndarray) -> None:
        sample([self], [dt], x[None, :])

    def update(self, z: float, R: float, gate: float | None) -> tuple[float, float, float, bool]:
        """(y, S, NIS, applied) of one reading; not applied beyond the gate."""
        H = self.bank.H
        x, P = self.x, self.P
        PHt = P @ H
        y = z - float(H @ x)
        S = float(H @ PHt) + R
        nis = y * y / S
        if gate is not None and nis > gate:
            return y, S, nis, False
        K = PHt / S
        x += K * y
        P -= K[:, None] * PHt  # P − K H P (PHt = P Hᵀ, P symmetric)
        self._phase_rate()
        return y, S, nis, True

    def _phase_rate(self) -> None:
        """The resonators' phase advance since the last update, beyond their ω."""
        b, r = self.bank, self.row
        w0 = b.W0
        x = b.X[r]
        c, s = x[w0::2], x[w0 + 1::2]
        pt, pc, ps = b.prev_t[r], b.prev_c[r].copy(), b.prev_s[r].copy()
        b.prev_t[r], b.prev_c[r], b.prev_s[r] = self.t, c, s
        if not self.t > pt:  # (NaN: no update before)
            return
        dt = self.t - pt
        # arg(z · conj(z_prev)) / dt, z = c + i s
        dphi = np.arctan2(s * pc - c * ps, c * pc + s * ps)
        energy = c * c + s * s
        b.observe_phase(energy, dphi / dt - b.omega)

    # -- what is published -----------------------------------------------------------
    @property
    def draft(self) -> float:
        return float(self.x[self.bank.idx].sum())

    @property
    def draft_var(self) -> float:
        idx = self.bank.idx
        return float(self.P[np.ix_(idx, idx)].sum())

    @property
    def mean(self) -> float:
        return float(self.x[0])

    @property
    def mean_var(self) -> float:
        return float(self.P[0, 0])

    @property
    def rate(self) -> float:
        """The level's rate: its own (cargo) and the squat's as the speed changes."""
        return float(self.x[1] + self.x[3] * self.u_rate)

    @property
    def rate_var(self) -> float:
        r = self.u_rate
        return float(self.P[1, 1] + 2.0 * r * self.P[1, 3] + r * r * self.P[3, 3])

    @property
    def squat_coefficient(self) -> float:
        """κ, m per (m/s)² of STW: the squat this mark has shown, per speed squared."""
        return float(self.x[3])

    @property
    def amplitude(self) -> float:
        return math.sqrt(2.0 * self._wave2)

    def peak_period(self) -> float:
        """The period of the resonator holding most of the sea, s."""
        return float(2.0 * math.pi / self.bank.omega[int(np.argmax(self.var_k))])


def sample(marks: list[WaveMark], dts: list[float], X: np.ndarray) -> None:
    """Every SAMPLE_STEP, for these marks (their states X, one row each, as they are
    now): each resonator's share of the sea, the mean of its energy over the window
    (from the start, the mean since then: the prior's 0.3 m would take minutes to
    fade), and the wave part's mean square for the amplitude. Both are means over tens
    of seconds: ten samples a second hold them."""
    bank = marks[0].bank
    w0 = bank.W0
    rows = [m.row for m in marks]
    a = np.array([min(1.0, dt / min(m.window, max(m.t - m.t0, dt))) for m, dt in zip(marks, dts)])[:, None]
    c, s = X[:, w0::2], X[:, w0 + 1::2]
    energy = 0.5 * (c * c + s * s)
    floor2 = np.array([m.floor2 for m in marks])[:, None]
    var_k = np.maximum((1.0 - a) * bank.var_k[rows] + a * energy, floor2)
    bank.var_k[rows] = var_k
    bank.var2[rows] = np.repeat(var_k, 2, axis=1)
    for m, dt, w in zip(marks, dts, c.sum(axis=1).tolist()):
        m._wave_n += 1
        aw = max(min(1.0, dt / m.amp_window), 1.0 / m._wave_n)
        m._wave2 = (1.0 - aw) * m._wave2 + aw * w * w
        m._sampled = m.t


def _moved(marks: list[WaveMark], ts: list[float], dts: list[float], speeds: list[tuple[float | None, float]],
           X: np.ndarray) -> None:
    """After a stacked predict (X: the marks' predicted states, one row each): each
    mark's time and speed, and the samples that are due (`sample`). A reading at the
    mark's own time (dt 0) made no step, as in `WaveMark.predict`."""
    due: list[int] = []
    for i, (m, t, dt, (u, u_rate)) in enumerate(zip(marks, ts, dts, speeds)):
        if dt > 0.0:
            m.u, m.u_rate = u, (u_rate if u is not None else 0.0)
            m.t = t
            if t - m._sampled >= SAMPLE_STEP:
                due.append(i)
    if due:
        sample([marks[i] for i in due], [marks[i].t - marks[i]._sampled for i in due],
               X if len(due) == len(marks) else X[due])


def step_marks(marks: list[WaveMark], ts: list[float], zs: list[float], Rs: list[float],
               speeds: list[tuple[float | None, float]], gate: float | None) -> tuple[np.ndarray, ...]:
    """One reading for each of several marks of one bank (each mark at most once): the
    same predict and update as `WaveMark.predict` and `WaveMark.update`, made on the
    bank's stacked states, so that numpy's cost per call is paid once for six marks.

    Why: at 100 Hz six marks are 600 small filters a second, and on 28 states a
    filter's arithmetic is cheap beside numpy's own overhead per call (a few µs). The
    marks are independent filters (they share only the bank's ω and Q), so stacking
    them changes no equation; `tests/draft/test_filters.py` checks both agree. When
    every mark of the bank reads once, in its order, with one step size (nearly every
    step at 100 Hz), the same equations run compiled (`kernel.py`, `_step_compiled`).

    Returns (y, S, NIS, applied), one per mark in the order given, as
    `WaveMark.update` does for one.
    """
    bank = marks[0].bank
    B = len(marks)
    rows = [m.row for m in marks]
    # every mark once, in the bank's order (the core sends them so): its arrays as they
    # are; otherwise the rows taken out and put back
    sel: slice | list[int] = slice(None) if B == bank.rows and rows == list(range(B)) else rows
    if sel.__class__ is slice and _kernel() is not None:
        dt0 = ts[0] - marks[0].t
        if dt0 > 0.0 and all(t - m.t == dt0 for t, m in zip(ts, marks)):
            return _step_compiled(bank, marks, ts, zs, Rs, speeds, gate, dt0)
    dts = [max(t - m.t, 0.0) for t, m in zip(ts, marks)]
    X, P = _predict_stacked(bank, marks, sel, dts, speeds)
    _moved(marks, ts, dts, speeds, X)
    # -- update: z = H x + v
    H = bank.H
    PHt = P @ H
    y = np.array(zs) - X @ H
    S = PHt @ H + np.array(Rs)
    nis = y * y / S
    applied = np.ones(B, dtype=bool) if gate is None else nis <= gate
    K = PHt / S[:, None]
    if not applied.all():
        K[~applied] = 0.0
    X += K * y[:, None]
    P -= K[:, :, None] * PHt[:, None, :]  # P − K H P
    _phase_stacked(bank, marks, sel, X, applied)
    bank.X[sel], bank.P[sel] = X, P
    return y, S, nis, applied


def _predict_stacked(bank: WaveBank, marks: list[WaveMark], sel: slice | list[int], dts: list[float],
                     speeds: list[tuple[float | None, float]]) -> tuple[np.ndarray, np.ndarray]:
    """`step_marks`'s predict of the rows `sel`, each by its dt: x ← F x,
    P ← F P Fᵀ + Q (the level's jerk, κ's walk, each resonator's drive), then the
    squat's d ← d + Δu·κ. Returns the predicted states and covariances."""
    B, n = len(marks), bank.n
    X, P = bank.X[sel], bank.P[sel]
    if all(dt == dts[0] for dt in dts):
        F, unit, level_q = bank.transition(dts[0])
        X = X @ F.T
        P = F @ P @ F.T
        P[:, :4, :4] += level_q
    else:
        got = [bank.transition(dt) for dt in dts]
        F = np.stack([g[0] for g in got])
        unit = np.stack([g[1] for g in got])
        X = np.einsum("bij,bj->bi", F, X)
        P = F @ P @ F.transpose(0, 2, 1)
        P[:, :4, :4] += np.stack([g[2] for g in got])
    P.reshape(B, n * n)[:, bank.wave_diag] += bank.var2[sel] * unit
    # the squat: d ← d + Δu·κ, P ← J P Jᵀ with J = I + Δu e₀e₃ᵀ
    du = [u - m.u if dt > 0.0 and u is not None and m.u is not None and u != m.u else 0.0
          for m, dt, (u, _) in zip(marks, dts, speeds)]
    if any(du):
        d = np.array(du)
        X[:, 0] += d * X[:, 3]
        P[:, 0, :] += d[:, None] * P[:, 3, :]
        P[:, :, 0] += d[:, None] * P[:, :, 3]
    return X, P


def _phase_stacked(bank: WaveBank, marks: list[WaveMark], sel: slice | list[int], X: np.ndarray,
                   applied: np.ndarray) -> None:
    """`step_marks`'s phase advance of each updated mark since its last update, beyond
    ω (for the retune), and the resonators kept for the next."""
    w0 = bank.W0
    t_now = np.array([m.t for m in marks])
    C, Sn = X[:, w0::2], X[:, w0 + 1::2]
    pt = bank.prev_t[sel]
    have = applied & (t_now > pt)  # (NaN: no update before)
    pc, ps = bank.prev_c[sel], bank.prev_s[sel]
    if have.all():  # every mark used and updated before (nearly always): no masks
        dphi = np.arctan2(Sn * pc - C * ps, C * pc + Sn * ps)
        bank.observe_phase(C * C + Sn * Sn, dphi / (t_now - pt)[:, None] - bank.omega)
    elif have.any():
        dphi = np.arctan2(Sn * pc - C * ps, C * pc + Sn * ps)
        energy = (C * C + Sn * Sn) * have[:, None]
        dt_p = np.where(have, t_now - np.where(have, pt, 0.0), 1.0)
        bank.observe_phase(energy, dphi / dt_p[:, None] - bank.omega)
    if applied.all():
        bank.prev_c[sel], bank.prev_s[sel], bank.prev_t[sel] = C, Sn, t_now
    else:
        keep = applied[:, None]
        bank.prev_c[sel] = np.where(keep, C, pc)
        bank.prev_s[sel] = np.where(keep, Sn, ps)
        bank.prev_t[sel] = np.where(applied, t_now, pt)


#: kernel.py once imported (False: not yet; None: numba missing, numpy only). Imported
#: at the first step, not with this module: a daemon whose draft estimator runs in its
#: own process never loads numba (0.3 s of start-up) in the main one.
_KERNEL: Any = False


def _kernel() -> Any:
    global _KERNEL
    if _KERNEL is False:
        try:
            from . import kernel
        except ImportError:  # numba is the optional extra `fast`: numpy without it
            kernel = None
        _KERNEL = kernel
    return _KERNEL


def _step_compiled(bank: WaveBank, marks: list[WaveMark], ts: list[float], zs: list[float], Rs: list[float],
                   speeds: list[tuple[float | None, float]], gate: float | None,
                   dt: float) -> tuple[np.ndarray, ...]:
    """`step_marks` for every mark of the bank in its order, one step size dt > 0: the
    same equations, compiled (`kernel.py`), on the bank's arrays in place."""
    B = len(marks)
    F, unit, level_q = bank.transition(dt)  # (made for the first dt of its rounded key)
    cs, sn = bank.rotation(dt)
    du = np.array([u - m.u if u is not None and m.u is not None and u != m.u else 0.0
                   for m, (u, _) in zip(marks, speeds)])
    X, P = bank.X, bank.P
    _kernel().predict_marks(X, P, cs, sn, float(F[0, 1]), float(F[0, 2]), level_q, bank.var2 * unit, du)
    _moved(marks, ts, [dt] * B, speeds, X)
    y, S, nis = np.empty(B), np.empty(B), np.empty(B)
    applied = np.empty(B, dtype=np.bool_)
    _kernel().update_marks(X, P, np.array(zs), np.array(Rs), math.inf if gate is None else gate,
                         np.array(ts), bank.prev_c, bank.prev_s, bank.prev_t, bank.omega,
                         bank._err, bank._wsum, y, S, nis, applied)
    return y, S, nis, applied
