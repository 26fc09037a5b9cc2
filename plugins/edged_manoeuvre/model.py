"""What the two kinematic models share: angles, Runge–Kutta, measurement rows.

Both models (seed 002, Table 1) are continuous-time, ẋ = f(x) + w, measured at
discrete times, z_k = h(x(t_k)) + v_k (Table 2). The filters integrate f with the
classical fourth-order Runge–Kutta method in sub-steps of at most `substep` seconds
(paper: δt = 0.005 s inside Δt = 0.1 s, §3.1), so a measurement is met at its own
time whatever the sensors' rates.

Measurements are updated one sensor at a time with that sensor's rows of h only
(`KINDS`): a position fix (p_n, p_e), a heading (ψ), a yaw rate (r), the body
accelerations (a_x, a_y as the accelerometers read them). Angle rows are wrapped to
(−π, π] in every residual, and ψ is kept in [0, 2π): the paper's first named failure
(heading switching between 0 and 360° blew the innovations up, §5.3) cannot happen.

With `bias` the state has two more entries, the accelerometers' slowly wandering
biases (b_x, b_y), seen only through the accelerometer rows: a MEMS unit's few mm/s²
of bias, taken for acceleration, would otherwise move the velocities by several cm/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from edged.angles import wrap_2pi, wrap_pi

DEG = math.pi / 180.0

#: Index of ψ (heading, rad, from north, clockwise) and r (yaw rate) in both models.
PSI, R = 4, 5
#: Index of the accelerometer biases when the state has them.
BX, BY = 8, 9


class YawAcceleration:
    """ṙ as a state of its own, a first-order Gauss–Markov process (Singer's model for
    the yaw acceleration), appended after the model's other states:

        ψ̇ = r        ṙ = r_dot        (d/dt) r_dot = −r_dot / τ + w

    The paper's ṙ = 0 holds r between readings: a yacht yawing ±7 °/s in a seaway
    changes r by ~1 °/s in the 0.1 s between two gyro readings, more than a gyro's own
    error a hundredfold, and the filter's r (and the heading it integrates) then lags
    the gyro. With r_dot the model carries the wave's yaw between readings; τ (a few
    seconds) keeps it from carrying it minutes ahead. τ = 0: no such state (the paper).
    """

    def __init__(self, tau: float, first: int) -> None:
        self.tau = float(tau)
        #: The index of r_dot in the state (None: the model has none).
        self.index: int | None = first if tau > 0.0 else None

    @property
    def size(self) -> int:
        return 0 if self.index is None else 1

    def f(self, x: np.ndarray | list[float], d: np.ndarray | list[float]) -> None:
        """Adds ψ̇'s companion rows to d = f(x): ṙ = r_dot, (d/dt) r_dot = −r_dot/τ.
        x and d: one state as a list of floats (`transition`), or arrays (…, n)."""
        i = self.index
        if i is None:
            return
        if isinstance(d, list):
            d[R] = x[i]
            d[i] = -x[i] / self.tau
        else:
            d[..., R] = x[..., i]
            d[..., i] = -x[..., i] / self.tau

    def F(self, A: np.ndarray) -> None:
        i = self.index
        if i is not None:
            A[R, i] = 1.0
            A[i, i] = -1.0 / self.tau




def circular_mean(angles: np.ndarray, weights: np.ndarray | None = None) -> float:
    """The mean direction of `angles` (weights may be negative, as unscented weights
    are): atan2 of the weighted mean of sines and cosines, in [0, 2π)."""
    w = np.full(len(angles), 1.0 / len(angles)) if weights is None else weights
    return float(wrap_2pi(math.atan2(float(w @ np.sin(angles)), float(w @ np.cos(angles)))))


@dataclass(frozen=True)
class Kind:
    """One sensor's rows of h: how many, and which of them are angles."""

    name: str
    dim: int
    angle_rows: tuple[int, ...] = ()


#: The measurement kinds of Table 2, split by sensor.
KINDS = {
    "position": Kind("position", 2),
    "heading": Kind("heading", 1, (0,)),
    "yaw_rate": Kind("yaw_rate", 1),
    "accel": Kind("accel", 2),
    #: the GNSS's own velocity over ground (its Doppler SOG/COG as north, east)
    "velocity": Kind("velocity", 2),
}


def say(kind: str, v: np.ndarray, size: bool = False) -> str:
    """A reading of a kind (or, with `size`, the size of a difference between two), in
    the units a navigator reads: health's words."""
    if kind in ("heading", "yaw_rate"):
        x = abs(float(v[0])) if size else float(v[0])
        return f"{x / DEG:.1f}°" if kind == "heading" else f"{x / DEG:.3f}°/s"
    unit = {"position": "m", "velocity": "m/s"}.get(kind, "m/s²")
    if size:
        return f"{float(np.max(np.abs(v)) if unit == 'm/s²' else np.hypot(v[0], v[1])):.3g} {unit}"
    return f"{', '.join(f'{float(x):.3g}' for x in v)} {unit}"


def rk4(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, dt: float, substep: float) -> np.ndarray:
    """x(t + dt) from ẋ = f(x) by classical Runge–Kutta in ⌈dt/substep⌉ equal steps.

    `x` may be one state (n,) or an ensemble (N, n): f works on the last axis.
    """
    if dt <= 0.0:
        return x
    steps = max(1, math.ceil(dt / substep - 1e-9))
    h = dt / steps
    for _ in range(steps):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


#: f and F of one state as the filters integrate it: x a list of floats, f(x) a list.
Floats = list[float]


def rk4_step(f: Callable[[Floats], Floats], x: Floats, h: float) -> tuple[Floats, Floats]:
    """One classical Runge–Kutta step of h seconds of one state, as floats, and the
    step's midpoint x + h/2·f(x) (its second stage). Each entry takes the same
    operations as `rk4`'s arrays, so the same bits; for a state of 8–11 entries numpy
    would spend ten times the arithmetic in its per-call cost."""
    half = 0.5 * h
    k1 = f(x)
    xm = [a + half * b for a, b in zip(x, k1)]
    k2 = f(xm)
    k3 = f([a + half * b for a, b in zip(x, k2)])
    k4 = f([a + h * b for a, b in zip(x, k3)])
    sixth = h / 6.0
    return [a + sixth * (p + 2.0 * q + 2.0 * r + s) for a, p, q, r, s in zip(x, k1, k2, k3, k4)], xm


def transition(F: Callable[[Floats], np.ndarray], f: Callable[[Floats], Floats],
               x: np.ndarray, dt: float, substep: float) -> tuple[np.ndarray, np.ndarray]:
    """(x(t + dt), Φ): the state by Runge–Kutta and the state transition matrix of the
    linearised model over the same sub-steps, Φ = Π (I + A_k h + A_k² h²/2) with A_k
    the Jacobian ∂f/∂x at the sub-step's midpoint (x + h/2·f(x), RK4's own second
    stage): second order in h, as the continuous-discrete EKF's covariance needs
    (Frogerais et al. 2012). The state is integrated as floats (`rk4_step`), Φ as
    matrices."""
    n = x.shape[0]
    eye = _eye(n)
    if dt <= 0.0:
        return x, eye.copy()
    steps = max(1, math.ceil(dt / substep - 1e-9))
    h = dt / steps
    xs = x.tolist()
    phi = None
    for _ in range(steps):
        xs, xm = rk4_step(f, xs, h)
        Ah = F(xm) * h
        step = eye + Ah + 0.5 * (Ah @ Ah)
        phi = step if phi is None else step @ phi
    return np.array(xs), phi


_EYES: dict[int, np.ndarray] = {}


def _eye(n: int) -> np.ndarray:
    e = _EYES.get(n)
    if e is None:
        e = _EYES[n] = np.eye(n)
        e.flags.writeable = False
    return e


@dataclass
class Innovation:
    """One update's innovation: residual y (angle rows wrapped), its covariance S, the
    NIS yᵀS⁻¹y (eq. 25), the reciprocal condition number of S in the 1-norm (eq. 23),
    and whether the update was applied (False: gated out)."""

    y: np.ndarray
    S: np.ndarray
    nis: float
    rcond: float
    applied: bool


def rcond(S: np.ndarray) -> float:
    """Eq. (23): 1 / (‖S⁻¹‖₁ ‖S‖₁); 0 for a singular or non-finite S."""
    if S.shape == (1, 1):
        return 1.0 if math.isfinite(S[0, 0]) and S[0, 0] > 0.0 else 0.0
    if S.shape == (2, 2):  # closed form: the filter's usual case
        a, b, c, d = float(S[0, 0]), float(S[0, 1]), float(S[1, 0]), float(S[1, 1])
        det = a * d - b * c
        if not (math.isfinite(det) and det != 0.0):
            return 0.0
        norm = max(abs(a) + abs(c), abs(b) + abs(d))
        norm_adj = max(abs(d) + abs(c), abs(b) + abs(a))  # ‖S⁻¹‖₁ = ‖adj S‖₁ / |det S|
        return abs(det) / (norm * norm_adj)
    if not np.all(np.isfinite(S)):
        return 0.0
    try:
        inv = np.linalg.inv(S)
    except np.linalg.LinAlgError:
        return 0.0
    return float(1.0 / (np.abs(inv).sum(axis=0).max() * np.abs(S).sum(axis=0).max()))


def residual(kind: Kind, z: np.ndarray, zp: np.ndarray) -> np.ndarray:
    """z − zp with the kind's angle rows wrapped to (−π, π]."""
    y = np.asarray(z, dtype=float) - zp
    for i in kind.angle_rows:
        y[..., i] = wrap_pi(y[..., i])
    return y


def inv_small(S: np.ndarray) -> np.ndarray:
    """S⁻¹, in closed form for 1 × 1 and 2 × 2 (the sensors' sizes here)."""
    if S.shape == (1, 1):
        return np.array([[1.0 / S[0, 0]]])
    if S.shape == (2, 2):
        a, b, c, d = S[0, 0], S[0, 1], S[1, 0], S[1, 1]
        det = a * d - b * c
        return np.array([[d, -b], [-c, a]]) / det
    return np.linalg.inv(S)


#: The sensors that read states directly, the same in both models: the states they read
#: (consecutive). Their H is rows of the identity.
STATE_ROWS = {"position": (0, 1), "heading": (PSI,), "yaw_rate": (R,)}


def h_state(kind: str, x: np.ndarray) -> np.ndarray | None:
    """h of the sensors that read a state directly (`STATE_ROWS`); None for the others."""
    rows = STATE_ROWS.get(kind)
    if rows is None:
        return None
    return x[..., rows[0] : rows[-1] + 1].copy()


def H_state(kind: str, n: int) -> np.ndarray | None:
    """Their Jacobian (rows of the identity); None for the others."""
    if kind == "position":
        Hm = np.zeros((2, n))
        Hm[0, 0] = Hm[1, 1] = 1.0
    elif kind == "heading":
        Hm = np.zeros((1, n))
        Hm[0, PSI] = 1.0
    elif kind == "yaw_rate":
        Hm = np.zeros((1, n))
        Hm[0, R] = 1.0
    else:
        return None
    return Hm


def judge(y: np.ndarray, S: np.ndarray, gate: float | None) -> tuple[float, float, bool]:
    """(NIS, rcond(S), apply?) of an innovation: not applied when S is singular or the
    NIS is beyond the gate; every filter's update asks this before changing anything."""
    return judge_inv(y, S, gate)[:3]


def judge_inv(y: np.ndarray, S: np.ndarray, gate: float | None) -> tuple[float, float, bool, np.ndarray | None]:
    """`judge`, and S⁻¹ (None when S is singular): the gain needs it again."""
    rc = rcond(S)
    if rc <= 0.0:
        return float("inf"), rc, False, None
    Si = inv_small(S)
    nis = float(y @ Si @ y)
    return nis, rc, gate is None or nis <= gate, Si


def reset_position(x: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray) -> None:
    """The position from a fix alone (after a GNSS jump): z with covariance R, no
    correlation with the other states, in place."""
    x[0:2] = z
    P[0:2, :] = 0.0
    P[:, 0:2] = 0.0
    P[0:2, 0:2] = R
