"""The stacked marks' predict and update, compiled (numba), for the common step.

`waves.step_marks` filters one reading of each mark with numpy on the bank's stacked
states: about 35 numpy calls per step of six marks, each a few µs of numpy's own
overhead beside arithmetic that is tiny on 28 states. That was most of the draft
estimator's cost (about 20 µs a reading, 78 s of CPU for an hour's replay of six
marks at 100 Hz). These two functions make the same equations in loops that numba
compiles, using the model's structure instead of dense matrix products:

    predict   x ← F x,  P ← F P Fᵀ + Q            (waves.py: F(dt), Q(dt))
              F = diag(L(dt), 1, R_1, …, R_k):  L the level's [d, ḋ, d̈] block
              [[1, dt, dt²/2], [0, 1, dt], [0, 0, 1]], 1 for κ, R_i = a_i [[cos, −sin],
              [sin, cos]](ω_i dt) each resonator's damped rotation; so F P Fᵀ is F
              applied to the rows of P, then to its columns: O(n²), not O(n³).
              Q: the level's and κ's 4 × 4 block, and each resonator's drive on its
              two diagonal entries.
    squat     x₀ ← x₀ + Δu·x₃,  P ← J P Jᵀ with J = I + Δu e₀e₃ᵀ
    update    y = z − H x,  S = H P Hᵀ + R,  K = P Hᵀ / S (zero beyond the gate),
              x ← x + K y,  P ← P − K (P Hᵀ)ᵀ;  H = e₀ + Σ the resonators' first states
    phase     each resonator's phase advance since the mark's last update, beyond ω,
              weighted by its energy, summed for the retune (`WaveBank.observe_phase`)

The order of the additions differs from numpy's matrix products, so results agree
to rounding (about 1e-16 relative), not bit for bit; the same log still gives the
same output every time. `tests/draft/test_kernel.py` checks both paths agree.
Without numba (`ImportError`), `waves.step_marks` keeps to numpy.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["predict_marks", "update_marks"]


def _compiled(fn):  # type: ignore[no-untyped-def]
    """Compiled once and kept beside this file (or in NUMBA_CACHE_DIR); where neither
    can be written (a read-only install under a hardened service without that set),
    compiled at each start instead: about 2 s in the estimator's own process."""
    try:
        return njit(cache=True)(fn)
    except RuntimeError:  # numba: "cannot cache function ...: no locator available"
        return njit(fn)


@_compiled
def predict_marks(X: np.ndarray, P: np.ndarray, cs: np.ndarray, sn: np.ndarray, dt: float, h2: float,
                  level_q: np.ndarray, qd: np.ndarray, du: np.ndarray) -> None:  # pragma: no cover - compiled
    """In place, every row b of X (B × n) and P (B × n × n): the predict over dt, then
    the squat's Δu (du[b], 0 for none). dt, h2: F's dt and dt²/2 (as the bank made
    F); cs, sn: a_i cos(ω_i dt), a_i sin(ω_i dt); qd: each resonator state's drive
    variance over dt (B × 2k)."""
    B, n = X.shape
    k = (n - 4) // 2
    for b in range(B):
        x = X[b]
        p = P[b]
        # x ← F x
        x[0] = x[0] + dt * x[1] + h2 * x[2]
        x[1] = x[1] + dt * x[2]
        for i in range(k):
            j = 4 + 2 * i
            c, s = cs[i], sn[i]
            a0, a1 = x[j], x[j + 1]
            x[j] = c * a0 - s * a1
            x[j + 1] = s * a0 + c * a1
        # P ← F P: F on the rows
        for col in range(n):
            p[0, col] = p[0, col] + dt * p[1, col] + h2 * p[2, col]
            p[1, col] = p[1, col] + dt * p[2, col]
            for i in range(k):
                j = 4 + 2 * i
                c, s = cs[i], sn[i]
                a0, a1 = p[j, col], p[j + 1, col]
                p[j, col] = c * a0 - s * a1
                p[j + 1, col] = s * a0 + c * a1
        # P ← (F P) Fᵀ: F on the columns
        for row in range(n):
            p[row, 0] = p[row, 0] + dt * p[row, 1] + h2 * p[row, 2]
            p[row, 1] = p[row, 1] + dt * p[row, 2]
            for i in range(k):
                j = 4 + 2 * i
                c, s = cs[i], sn[i]
                a0, a1 = p[row, j], p[row, j + 1]
                p[row, j] = c * a0 - s * a1
                p[row, j + 1] = s * a0 + c * a1
        # + Q
        for i in range(4):
            for j in range(4):
                p[i, j] += level_q[i, j]
        for i in range(2 * k):
            p[4 + i, 4 + i] += qd[b, i]
        # the squat: J P Jᵀ, J = I + Δu e₀e₃ᵀ (row 0 += Δu row 3, then column 0 += Δu column 3)
        d = du[b]
        if d != 0.0:
            x[0] += d * x[3]
            for col in range(n):
                p[0, col] += d * p[3, col]
            for row in range(n):
                p[row, 0] += d * p[row, 3]


@_compiled
def update_marks(X: np.ndarray, P: np.ndarray, zs: np.ndarray, Rs: np.ndarray, gate: float,
                 t_now: np.ndarray, prev_c: np.ndarray, prev_s: np.ndarray, prev_t: np.ndarray,
                 omega: np.ndarray, err: np.ndarray, wsum: np.ndarray,
                 y_out: np.ndarray, S_out: np.ndarray, nis_out: np.ndarray,
                 applied_out: np.ndarray) -> None:  # pragma: no cover - compiled
    """In place: each row's update with its reading zs[b] (variance Rs[b]; not applied
    when y²/S > gate), then its phase advance since its last update (into err, wsum)
    and its resonators kept as the last update's (prev_c, prev_s at prev_t)."""
    B, n = X.shape
    k = (n - 4) // 2
    pht = np.empty(n)
    for b in range(B):
        x = X[b]
        p = P[b]
        # P Hᵀ and H x, H = e₀ + Σ e_(4+2i)
        hx = x[0]
        for i in range(k):
            hx += x[4 + 2 * i]
        for r in range(n):
            acc = p[r, 0]
            for i in range(k):
                acc += p[r, 4 + 2 * i]
            pht[r] = acc
        S = Rs[b] + pht[0]
        for i in range(k):
            S += pht[4 + 2 * i]
        y = zs[b] - hx
        nis = y * y / S
        ok = nis <= gate
        y_out[b], S_out[b], nis_out[b], applied_out[b] = y, S, nis, ok
        if not ok:
            continue
        for r in range(n):
            kr = pht[r] / S
            x[r] += kr * y
            for col in range(n):
                p[r, col] -= kr * pht[col]
        # the phase advance, arg(z · conj(z_prev)) / dt with z = c + i s
        t, pt = t_now[b], prev_t[b]
        have = t > pt  # (NaN: no update before)
        for i in range(k):
            c, s = x[4 + 2 * i], x[5 + 2 * i]
            if have:
                pc, ps = prev_c[b, i], prev_s[b, i]
                dphi = math.atan2(s * pc - c * ps, c * pc + s * ps)
                energy = c * c + s * s
                err[i] += energy * (dphi / (t - pt) - omega[i])
                wsum[i] += energy
            prev_c[b, i], prev_s[b, i] = c, s
        prev_t[b] = t
