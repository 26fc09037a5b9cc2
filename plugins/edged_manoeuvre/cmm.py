"""CMM: the curvilinear motion model (seed 002, eq. 3 and Tables 1 and 2).

State x = [p_n, p_e, v_n, v_e, ψ, r, a_t, a_n] (+ [b_x, b_y]): position, velocity over
ground north/east, heading and yaw rate, and the accelerations along (a_t) and across
(a_n, + to the right) the course-speed vector V = (v_n, v_e).

System model, eq. (3) and Table 1, with f^ox = v_n/|V| and f^oy = v_e/|V|:

    ṗ_n = v_n    ṗ_e = v_e
    v̇_n = a_t f^ox − a_n f^oy        v̇_e = a_t f^oy + a_n f^ox
    ψ̇ = r    ṙ = 0    ȧ_t = ȧ_n = 0    (ḃ = 0)

(with `yaw_tau` > 0, ṙ = r_dot, a state appended last: `model.YawAcceleration`)

Heading and course are separate states: the drift angle ψ − χ is free.

Measurement model, Table 2: the accelerometers read the inertial acceleration
(a_N, a_E) = (v̇_n, v̇_e) in body axes,

    z_ax = a_N cos ψ + a_E sin ψ (+ b_x)        z_ay = −a_N sin ψ + a_E cos ψ (+ b_y)

which is the paper's h_u1 cos ψ + h_u2 sin ψ − v r (eqs. 8, 11) once its r·v terms are
multiplied out: they cancel.

|V| → 0 makes f^ox, f^oy undefined (the model's kink the paper blames for the CMM+EKF
divergence, §5.2): below MIN_SPEED the course-speed direction is taken from the
heading, so f stays finite and smooth at rest.
"""

from __future__ import annotations

import numpy as np

from .model import BX, BY, PSI, R, H_state, YawAcceleration, h_state

NAMES = ("x", "y", "v_n", "v_e", "heading", "r", "a_t", "a_n", "b_x", "b_y")
VN, VE, AT, AN = 2, 3, 6, 7
#: Below this speed over ground (m/s) the course-speed direction is the heading's.
MIN_SPEED = 0.05


def _direction(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f^ox, f^oy, |V|) with the slow-speed fallback to the heading."""
    vn, ve = x[..., VN], x[..., VE]
    speed = np.hypot(vn, ve)
    slow = speed < MIN_SPEED
    safe = np.where(slow, 1.0, speed)
    fx = np.where(slow, np.cos(x[..., PSI]), vn / safe)
    fy = np.where(slow, np.sin(x[..., PSI]), ve / safe)
    return fx, fy, speed


class Cmm:
    name = "cmm"

    def __init__(self, bias: bool = False, yaw_tau: float = 0.0) -> None:
        base = 10 if bias else 8
        self.bias = bias
        self.yaw = YawAcceleration(yaw_tau, base)
        self.n = base + self.yaw.size
        self.names = NAMES[:base] + ("r_dot",) * self.yaw.size

    # -- system model -----------------------------------------------------------------
    def _accel_ne(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fx, fy, _ = _direction(x)
        at, an = x[..., AT], x[..., AN]
        return at * fx - an * fy, at * fy + an * fx

    def f(self, x: np.ndarray | list[float]) -> np.ndarray | list[float]:
        """ẋ = f(x), x (n,), (N, n) or one state as a list (`model.transition`)."""
        if isinstance(x, list):
            return self.f(np.array(x)).tolist()
        d = np.zeros_like(x)
        d[..., 0] = x[..., VN]
        d[..., 1] = x[..., VE]
        d[..., VN], d[..., VE] = self._accel_ne(x)
        d[..., PSI] = x[..., R]
        self.yaw.f(x, d)
        return d

    def _accel_ne_jacobian(self, x: np.ndarray) -> np.ndarray:
        """∂(a_N, a_E)/∂x (2, n)."""
        n = self.n
        J = np.zeros((2, n))
        fx, fy, speed = _direction(x)
        at, an = x[AT], x[AN]
        if speed >= MIN_SPEED:
            vn, ve = x[VN], x[VE]
            s3 = speed**3
            dfx = np.array([ve * ve, -vn * ve]) / s3  # ∂f^ox/∂(v_n, v_e)
            dfy = np.array([-vn * ve, vn * vn]) / s3
            J[0, VN:VE + 1] = at * dfx - an * dfy
            J[1, VN:VE + 1] = at * dfy + an * dfx
        else:  # the direction is the heading's
            J[0, PSI] = -at * fy - an * fx
            J[1, PSI] = at * fx - an * fy
        J[0, AT], J[0, AN] = fx, -fy
        J[1, AT], J[1, AN] = fy, fx
        return J

    def F(self, x: np.ndarray | list[float]) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        A = np.zeros((self.n, self.n))
        A[0, VN] = A[1, VE] = A[PSI, R] = 1.0
        A[VN:VE + 1, :] += self._accel_ne_jacobian(x)
        self.yaw.F(A)
        return A

    # -- measurement model ------------------------------------------------------------
    def h(self, kind: str, x: np.ndarray) -> np.ndarray:
        direct = h_state(kind, x)
        if direct is not None:
            return direct
        if kind == "accel":
            an_, ae_ = self._accel_ne(x)
            c, s = np.cos(x[..., PSI]), np.sin(x[..., PSI])
            ax, ay = an_ * c + ae_ * s, -an_ * s + ae_ * c
            if self.bias:
                ax, ay = ax + x[..., BX], ay + x[..., BY]
            return np.stack([ax, ay], axis=-1)
        if kind == "velocity":  # the velocity states themselves
            return np.stack([x[..., VN], x[..., VE]], axis=-1)
        raise KeyError(kind)

    def H(self, kind: str, x: np.ndarray) -> np.ndarray:
        n = self.n
        Hm = H_state(kind, n)
        if Hm is not None:
            return Hm
        Hm = np.zeros((2, n))
        if kind == "accel":
            c, s = np.cos(x[PSI]), np.sin(x[PSI])
            an_, ae_ = self._accel_ne(x)
            Ja = self._accel_ne_jacobian(x)
            Hm[0] = c * Ja[0] + s * Ja[1]
            Hm[1] = -s * Ja[0] + c * Ja[1]
            Hm[0, PSI] += -an_ * s + ae_ * c
            Hm[1, PSI] += -an_ * c - ae_ * s
            if self.bias:
                Hm[0, BX] = Hm[1, BY] = 1.0
        elif kind == "velocity":
            Hm[0, VN] = Hm[1, VE] = 1.0
        else:
            raise KeyError(kind)
        return Hm

    # -- between the state and the world ------------------------------------------------
    def from_motion(self, pn: float, pe: float, vn: float, ve: float, psi: float, r: float) -> np.ndarray:
        """Eqs. (14), (16), (17): velocities from two-point differencing, accelerations zero."""
        x = np.zeros(self.n)
        x[0], x[1], x[VN], x[VE], x[PSI], x[R] = pn, pe, vn, ve, psi, r
        return x

    def from_motion_jacobian(self, vn: float, ve: float, psi: float) -> np.ndarray:
        J = np.zeros((self.n, 6))
        for i, j in ((0, 0), (1, 1), (VN, 2), (VE, 3), (PSI, 4), (R, 5)):
            J[i, j] = 1.0
        return J

    def ground_velocity(self, x: np.ndarray) -> tuple[float, float]:
        return float(x[VN]), float(x[VE])

    def body(self, x: np.ndarray) -> np.ndarray:
        """[u, v, a_u, a_v]: u, v the ground velocity in body axes; a_u = u̇, a_v = v̇,
        the body-axis acceleration plus the Coriolis terms (u̇ = a_bx + r v)."""
        c, s = np.cos(x[PSI]), np.sin(x[PSI])
        vn, ve, r = x[VN], x[VE], x[R]
        u, v = vn * c + ve * s, -vn * s + ve * c
        an_, ae_ = self._accel_ne(x)
        abx, aby = an_ * c + ae_ * s, -an_ * s + ae_ * c
        return np.array([u, v, abx + r * v, aby - r * u])

    def body_var(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """The variances of `body`: diag J P Jᵀ."""
        J = self.body_jacobian(x)
        return np.diag(J @ P @ J.T)

    def body_jacobian(self, x: np.ndarray) -> np.ndarray:
        """∂body/∂x by central differences (the output's σ only; not on the filter's path)."""
        J = np.zeros((4, self.n))
        for j in range(self.n):
            h = 1e-6 * max(1.0, abs(x[j]))
            xp, xm = x.copy(), x.copy()
            xp[j] += h
            xm[j] -= h
            J[:, j] = (self.body(xp) - self.body(xm)) / (2 * h)
        return J

    def shift(self, x: np.ndarray, dn: float, de: float) -> None:
        x[..., 0] -= dn
        x[..., 1] -= de
