"""The vessel's motion over ground: a nearly-constant-acceleration Kalman filter.

State (local plane, `plane.py`):  x = [p_n, p_e, v_n, v_e, a_n, a_e]
Model, per axis (white jerk of spectral density q):
    p(k+1) = p + T·v + ½T²·a      v(k+1) = v + T·a      a(k+1) = a + w_a
    F = [[1, T, ½T²], [0, 1, T], [0, 0, 1]],  Q = q·[[T⁵/20, T⁴/8, T³/6], [T⁴/8, T³/3, T²/2], [T³/6, T²/2, T]]
Measurements:
    GNSS position   z = [p_n, p_e]                       R = σ_p²·I
    GNSS velocity   z = SOG·[cos COG, sin COG] = [v_n, v_e]   R = σ_v²·I (noise on the vector,
                    so that COG at low speed is not overweighted)
    accelerometer   z = R(ψ)·[a_x, a_y] = [a_n, a_e] + r·[−v_e, v_n]   R = σ_a²/n + (0.01 m/s²)²
    (with a rate of turn r the velocity turns with the hull: `transition`)

Seed 000 feeds the acceleration in as a control input; integrating a noisy 1 Hz
accelerometer that way adds a velocity random walk (≈ 0.27 m/s over 30 s at σ 0.05
m/s²). Here it is a *measured state* (ESTIMATORS.md §1): the accelerometer observes
`a`, GNSS observes `p` and `v`, and without an IMU `a` is still seen through the
velocity differences. The accelerometers' reading with gravity removed is the
inertial acceleration in body axes (it contains the −v·r, +u·r terms, DESIGN §2), so
rotating it by the heading gives the NED acceleration exactly.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .kalman import identity, innovation, innovation_rows, predict, update, update_rows, white_noise_q

P_N, P_E, V_N, V_E, A_N, A_E = range(6)
POS, VEL, ACC = slice(0, 2), slice(2, 4), slice(4, 6)
_H_ACC = np.eye(6)[ACC]
#: Bounds of the jerk density q learned from the data (m²/s⁵): from a laden ship holding
#: her speed (1e-9: the acceleration wanders by ~0.003 m/s² in 10 minutes) to a small
#: craft surging in a seaway (1e-2).
Q_MIN, Q_MAX = 1e-9, 1e-2
#: Step of log q per GNSS velocity update (covariance matching, below).
Q_GAIN = 0.1
#: An innovation counts at most this many times its dof: one manoeuvre (or one bad
#: fix) raises q by e^(Q_GAIN·(Q_UP − 1)) ≈ 1.5× per update, not by orders of magnitude
#: that the slow fixes of a large ship would take an hour to bring down again.
Q_UP = 5.0
#: The jerk density after the GNSS showed a manoeuvre the filter missed (m²/s⁵): an
#: order that changes the acceleration by 0.05 m/s² within 25 s (q·T = 0.05²). From
#: there q comes down again with the innovations; left at a laden ship's 1e-7, the
#: acceleration σ is back to 0.003 m/s² within a minute and the next change of the
#: order (the end of the slowing down) is missed the same way.
Q_ORDER = 1e-4
#: The manoeuvre watch (`DriftWatch`): the time constant (s) of the running mean of
#: the whitened innovations, and the χ² (2 dof, 99.9 %) its square may reach, in units
#: of its own variance, before the filter is told that the acceleration changed.
DRIFT_TAU = 2.0
DRIFT_GATE = 13.8
ACCEL_DRIFT_TAU = 4.0
#: The watch judges only a mean of several innovations (its variance V at most this,
#: about a dozen samples' worth): a lone 1 Hz or 30-s innovation is the gate's and
#: `adapt`'s to judge, and a single surprise must not loosen a sparse-fix filter.
DRIFT_MAX_VAR = 0.15
ACCEL_JUMP = 0.02


@functools.lru_cache(maxsize=64)
def _noise2(var: float) -> np.ndarray:
    """R = var·I₂ of a 2-D measurement (a configured σ²: made once; read-only)."""
    R = np.array([[var, 0.0], [0.0, var]])
    R.flags.writeable = False
    return R


class DriftWatch:
    """A change of acceleration the filter is too stiff to see (a ship's new orders).

    Why: with SOG at 10 Hz, R dominates each innovation, the NIS stays near its dof and
    `GroundFilter.adapt` lowers q to a laden ship's 1e-9; when the ship then starts or
    stops speeding up, each innovation is a fraction of its σ, and the velocity lagged
    by the change of acceleration × 10 s (0.14 m/s at 0.02 m/s², squat run). The
    innovations of a consistent filter are white; a lag makes them all lean one way.
    Their exponentially weighted mean (time constant DRIFT_TAU), each whitened by its
    S's Cholesky factor L,
        w = L⁻¹y,   m ← (1 − α)·m + α·w,   V ← (1 − α)²·V + α²,   α = min(Δt/τ, 1)
    has covariance V·I while they are white; mᵀm > DRIFT_GATE·V says they are not.
    Ramps of 0.02 m/s² are seen within 3–4 s from SOG alone (the information the
    readings hold: Σ(a·t/σ)² reaches the gate then), sooner with an accelerometer.


    The 2×2 algebra is written out (a step of a 10 Hz filter: a Cholesky factor and a
    triangular solve through LAPACK cost more than the filter's update): the whitened
    mean `m` only decides whether the gate is passed; `y` (kept as a pair of floats,
    each the same products and sums as the vector form) sets the velocity's inflation.
    """

    def __init__(self, tau: float = DRIFT_TAU) -> None:
        self.tau = tau
        self.m0 = self.m1 = 0.0
        self.y0 = self.y1 = 0.0  # the same mean of the innovations as they are (m/s, m/s²)
        self.V = 0.0
        self.t: float | None = None

    @property
    def y(self) -> np.ndarray:
        """The running mean of the innovations as a vector."""
        return np.array([self.y0, self.y1])

    def lean(self, t: float, y: np.ndarray, S: np.ndarray) -> bool:
        """Add one innovation; True when the recent ones lean beyond the gate.
        w = L⁻¹y with S = L Lᵀ: L = [[l₀₀, 0], [l₁₀, l₁₁]], l₀₀ = √S₀₀, l₁₀ = S₁₀/l₀₀,
        l₁₁ = √(S₁₁ − l₁₀²); w₀ = y₀/l₀₀, w₁ = (y₁ − l₁₀ w₀)/l₁₁ (the lower triangle,
        as LAPACK's potrf reads it)."""
        (s00, _), (s10, s11) = S.tolist()
        y0, y1 = y.tolist()
        if not s00 > 0.0:  # S not positive (or NaN): nothing to judge by
            return False
        l00 = math.sqrt(s00)
        l10 = s10 / l00
        d = s11 - l10 * l10
        if not d > 0.0:
            return False
        w0 = y0 / l00
        w1 = (y1 - l10 * w0) / math.sqrt(d)
        if not (math.isfinite(w0) and math.isfinite(w1)):
            return False
        a = 1.0 if self.t is None else min(max(t - self.t, 1e-3) / self.tau, 1.0)
        self.t = t
        b = 1.0 - a
        self.m0, self.m1 = b * self.m0 + a * w0, b * self.m1 + a * w1
        self.y0, self.y1 = b * self.y0 + a * y0, b * self.y1 + a * y1
        self.V = b**2 * self.V + a * a
        return self.V <= DRIFT_MAX_VAR and self.m0 * self.m0 + self.m1 * self.m1 > DRIFT_GATE * self.V

    def clear(self) -> None:
        self.m0 = self.m1 = self.y0 = self.y1 = 0.0
        self.V = 0.0


def transition(T: float, r: float = 0.0) -> np.ndarray:
    """F for a step of T seconds, states ordered [p_n, p_e, v_n, v_e, a_n, a_e].

    With a rate of turn r (rad/s, + clockwise) the velocity turns with the hull (a
    coordinated turn, r from the gyro: linear given r), θ = r·T:
        v(k+1) = Rot(θ)·v + T·a,   p(k+1) = p + (1/r)·[[sin θ, −(1 − cos θ)], [1 − cos θ, sin θ]]·v + ½T²·a
    so that a turning ship's ground velocity between 30-s fixes swings round instead of
    being blended (shortened) between its old and new directions; `a` is then the
    acceleration besides the turn's (speed changes). Without a turn F depends on T
    alone and is the one kept for that T (read-only)."""
    th = r * T
    if not abs(th) > 1e-9:
        return _straight(T)
    F = _straight(T).copy()
    c, s = math.cos(th), math.sin(th)
    F[V_N, V_N], F[V_N, V_E], F[V_E, V_N], F[V_E, V_E] = c, -s, s, c
    F[P_N, V_N] = F[P_E, V_E] = s / r
    F[P_N, V_E], F[P_E, V_N] = -(1.0 - c) / r, (1.0 - c) / r
    return F


@functools.lru_cache(maxsize=256)
def _straight(T: float) -> np.ndarray:
    """F of a step of T s without a turn (read-only: shared)."""
    F = np.eye(6)
    F[P_N, V_N] = F[P_E, V_E] = F[V_N, A_N] = F[V_E, A_E] = T
    F[P_N, A_N] = F[P_E, A_E] = 0.5 * T * T
    F.flags.writeable = False
    return F


@functools.lru_cache(maxsize=256)
def _jerk_q(T: float) -> np.ndarray:
    """Q of white jerk of unit density (`kalman` (Q3)) on both axes, the states ordered
    by derivative [p_n, p_e, v_n, v_e, a_n, a_e]: element (2i + k, 2j + k) is (Q3)'s
    (i, j) for axis k (read-only: shared)."""
    Q = np.kron(white_noise_q(3, T), identity(2))
    Q.flags.writeable = False
    return Q


@functools.lru_cache(maxsize=256)
def process_noise(T: float, q: float) -> np.ndarray:
    """Q of white jerk of density q (m²/s⁵), q·(Q3) on both axes.

    Kept for each (T, q) seen lately: a sensor's interval and the agility q repeat (a
    10 Hz GNSS replay: 8570 predictions, 36 distinct pairs). Read-only, as it is shared."""
    Q = _jerk_q(T) * q
    Q.flags.writeable = False
    return Q


class GroundFilter:
    """Position, velocity and acceleration over ground, predicted to each measurement."""

    def __init__(self, t: float, v_n: float, v_e: float, sog_sigma: float, jerk_density: float, accel_sigma0: float = 0.1) -> None:
        self.t = t
        self.q = min(max(jerk_density, Q_MIN), Q_MAX)
        self.x = np.array([0.0, 0.0, v_n, v_e, 0.0, 0.0])
        self.P = np.diag([1e4, 1e4, sog_sigma**2, sog_sigma**2, accel_sigma0**2, accel_sigma0**2])
        self.have_position = False
        #: Rate of turn (rad/s) the next prediction turns the velocity by (set by the
        #: vector model from the gyro or the heading; 0 when neither is fresh).
        self.r = 0.0
        #: The manoeuvre watches on the GNSS velocity's and the accelerometers'
        #: innovations, and how often they raised q (`DriftWatch`).
        self._watch = {"velocity": DriftWatch(), "accel": DriftWatch(ACCEL_DRIFT_TAU)}
        self.manoeuvres = 0

    def predict(self, t: float) -> None:
        T = t - self.t
        if T <= 0.0:
            return
        self.x, self.P = predict(self.x, self.P, transition(T, self.r), process_noise(T, self.q))
        self.t = t

    def predicted(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """State and covariance at t, without changing the filter (published ticks)."""
        T = t - self.t
        if T <= 0.0:
            return self.x, self.P
        F = transition(T, self.r)
        return np.dot(F, self.x), np.dot(np.dot(F, self.P), F.T) + process_noise(T, self.q)

    # Each `try_*` predicts to the measurement, gates it and updates; it returns the
    # NIS and whether it was used.
    def try_position(self, n: float, e: float, sigma: float, gate: float) -> tuple[float, bool]:
        z = np.array([n, e])
        R = _noise2(sigma * sigma)
        if not self.have_position:
            # The first fix places the plane's origin: take it as it is.
            self.x[POS] = z
            self.P[POS, :] = 0.0
            self.P[:, POS] = 0.0
            self.P[POS, POS] = R
            self.have_position = True
            return 0.0, True
        y, S, nis = innovation_rows(self.x, self.P, z, R, POS)
        if not nis <= gate:  # NaN fails too
            return nis, False
        self.x, self.P = update_rows(self.x, self.P, y, S, R, POS)
        return nis, True

    def adapt(self, nis: float, dof: int) -> None:
        """The vessel's agility from the data (covariance matching): a consistent
        filter's velocity NIS has mean `dof`. Innovations larger than predicted mean the
        motion changes faster than q allows, smaller ones that q lets the velocity
        wander more than it does (between 30-s fixes it then follows the IMU's noise):
            log q ← log q + Q_GAIN·(min(ν/dof, Q_UP) − 1),   Q_MIN ≤ q ≤ Q_MAX
        So one default holds from a tanker with a fix every 30 s to a yacht at 1 Hz;
        where the prediction interval is short and R dominates, q barely matters."""
        if not math.isfinite(nis):
            return
        step = Q_GAIN * (min(nis / dof, Q_UP) - 1.0)
        self.q = min(max(self.q * math.exp(step), Q_MIN), Q_MAX)

    def try_velocity(self, v_n: float, v_e: float, sigma: float, gate: float) -> tuple[float, bool]:
        z = np.array([v_n, v_e])
        R = _noise2(sigma * sigma)
        y, S, nis = innovation_rows(self.x, self.P, z, R, VEL)
        self.adapt(nis, 2)
        if self._watched("velocity", y, S):
            S = self.P[VEL, VEL] + R  # (K4) again: the watch widened P
        if not nis <= gate:  # NaN fails too
            return nis, False
        self.x, self.P = update_rows(self.x, self.P, y, S, R, VEL)
        return nis, True

    def try_accel(self, a_n: float, a_e: float, var: float, gate: float) -> tuple[float, bool]:
        """The accelerometers see the turn's acceleration too: z = a + r·[−v_e, v_n]."""
        z = np.array([a_n, a_e])
        R = _noise2(var)
        H = _H_ACC.copy()
        H[0, V_E], H[1, V_N] = -self.r, self.r
        y, S, nis = innovation(self.x, self.P, z, R, H)
        if self._watched("accel", y, S):
            y, S, _ = innovation(self.x, self.P, z, R, H)  # (K4) again: the watch widened P
        if not nis <= gate:  # NaN fails too
            return nis, False
        self.x, self.P = update(self.x, self.P, y, S, R, H)
        return nis, True

    def _watched(self, kind: str, y: np.ndarray, S: np.ndarray) -> bool:
        """Widen the velocity's and the acceleration's covariance when a watch sees the
        innovations lean one way; whether it did (the update then needs S anew)."""
        watch = self._watch[kind]
        if not watch.lean(self.t, y, S):
            return False
        lag = float(watch.y @ watch.y) if kind == "velocity" else 0.0
        self.P[VEL, VEL] += np.eye(2) * lag
        self.P[ACC, ACC] += np.eye(2) * ACCEL_JUMP**2
        self.manoeuvres += 1
        for w in self._watch.values():
            w.clear()
        return True

    def reset_position(self, n: float, e: float, sigma: float) -> None:
        """Trust the GNSS again after a jump the gate kept rejecting (a new antenna,
        a receiver that re-converged): the position restarts at the fix."""
        self.x[POS] = (n, e)
        self.P[POS, :] = 0.0
        self.P[:, POS] = 0.0
        self.P[POS, POS] = np.eye(2) * sigma * sigma

    def reset_velocity(self, v_n: float, v_e: float, sigma: float) -> None:
        """Trust the GNSS velocity again: the motion changed faster than q allowed."""
        self.q = max(self.q, Q_ORDER)
        self.x[VEL] = (v_n, v_e)
        self.x[ACC] = 0.0
        self.P[VEL, :] = 0.0
        self.P[:, VEL] = 0.0
        self.P[ACC, :] = 0.0
        self.P[:, ACC] = 0.0
        self.P[VEL, VEL] = np.eye(2) * sigma * sigma
        self.P[ACC, ACC] = np.eye(2) * 0.01

    def shift(self, dn: float, de: float) -> None:
        """The plane moved its origin by (dn, de): positions follow."""
        self.x[P_N] -= dn
        self.x[P_E] -= de

    @staticmethod
    def speed(x: np.ndarray) -> float:
        return math.hypot(x[V_N], x[V_E])
