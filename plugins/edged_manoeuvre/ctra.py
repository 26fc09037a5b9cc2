"""CTRA: constant turn rate and acceleration in body axes (seed 002, Tables 1 and 2).

State x = [p_n, p_e, u, v, ψ, r, a_u, a_v] (+ [b_x, b_y] with accelerometer biases):
position north/east in the local tangent plane (m), surge and sway speed over ground
in body axes (m/s, v + to starboard), heading (rad, from north, clockwise), yaw rate
(rad/s, + to starboard), and the rates of change of u and v in body axes (m/s²).

System model, eqs. (4)–(5) and Table 1:

    ṗ_n = u cos ψ − v sin ψ        ṗ_e = u sin ψ + v cos ψ
    u̇ = a_u    v̇ = a_v    ψ̇ = r    ṙ = 0    ȧ_u = ȧ_v = 0    (ḃ = 0)

With `yaw_tau` > 0 the yaw acceleration is a state of its own, appended last
(`model.YawAcceleration`): ṙ = r_dot, (d/dt) r_dot = −r_dot/τ.

Measurement model, eqs. (10)–(12) and Table 2: positions, heading and yaw rate are
states; the accelerometers read the body-axis acceleration, which holds the Coriolis
terms (a body turning at r carries its velocity round with it):

    z_ax = a_u − v r (+ b_x)        z_ay = a_v + u r (+ b_y)

The Jacobians are written out (the EKF's, analytic as the issue asks); each is checked
against a numerical derivative in the tests.
"""

from __future__ import annotations

import math

import numpy as np

from .model import BX, BY, PSI, R, H_state, YawAcceleration, h_state

NAMES = ("x", "y", "u", "v", "heading", "r", "a_u", "a_v", "b_x", "b_y")
U, V, AU, AV = 2, 3, 6, 7


class Ctra:
    name = "ctra"

    def __init__(self, bias: bool = False, yaw_tau: float = 0.0) -> None:
        base = 10 if bias else 8
        self.bias = bias
        self.yaw = YawAcceleration(yaw_tau, base)
        self.n = base + self.yaw.size
        self.names = NAMES[:base] + ("r_dot",) * self.yaw.size
        # F's entries that do not depend on the state, set once (`F` copies them)
        self._F0 = np.zeros((self.n, self.n))
        self._F0[U, AU] = self._F0[V, AV] = self._F0[PSI, R] = 1.0
        self.yaw.F(self._F0)
        self._F0.flags.writeable = False
        self._zeros = [0.0] * (self.n - 5)  # the tail of f after ψ̇ (ṙ = 0, ȧ = 0, ḃ = 0)

    # -- system model (Table 1) ------------------------------------------------------
    def f(self, x: np.ndarray | list[float]) -> np.ndarray | list[float]:
        """ẋ = f(x); x one state (a list of floats gives a list: `model.transition`),
        of shape (n,) or (N, n)."""
        if isinstance(x, list) or x.ndim == 1:  # one state: scalar maths, no array ops
            u, v, psi = float(x[U]), float(x[V]), float(x[PSI])
            c, s = math.cos(psi), math.sin(psi)
            d = [u * c - v * s, u * s + v * c, float(x[AU]), float(x[AV]), float(x[R])]  # eqs. (4), (5)
            d += self._zeros
            self.yaw.f(x, d)
            return d if isinstance(x, list) else np.array(d)
        u, v, psi = x[..., U], x[..., V], x[..., PSI]
        c, s = np.cos(psi), np.sin(psi)
        d = np.zeros_like(x)
        d[..., 0] = u * c - v * s  # eq. (4)
        d[..., 1] = u * s + v * c  # eq. (5)
        d[..., U] = x[..., AU]
        d[..., V] = x[..., AV]
        d[..., PSI] = x[..., R]
        self.yaw.f(x, d)
        return d

    def F(self, x: np.ndarray | list[float]) -> np.ndarray:
        """∂f/∂x at x (one state, (n,) or a list): the constant entries, then these."""
        u, v, psi = float(x[U]), float(x[V]), float(x[PSI])
        c, s = math.cos(psi), math.sin(psi)
        A = self._F0.copy()
        A[0, U], A[0, V], A[0, PSI] = c, -s, -u * s - v * c
        A[1, U], A[1, V], A[1, PSI] = s, c, u * c - v * s
        return A

    # -- measurement model (Table 2), one sensor's rows ----------------------------------
    def h(self, kind: str, x: np.ndarray) -> np.ndarray:
        direct = h_state(kind, x)
        if direct is not None:
            return direct
        if kind == "accel":
            u, v, r = x[..., U], x[..., V], x[..., R]
            ax = x[..., AU] - v * r  # eq. (11)
            ay = x[..., AV] + u * r  # eq. (12)
            if self.bias:
                ax, ay = ax + x[..., BX], ay + x[..., BY]
            return np.array([ax, ay]) if x.ndim == 1 else np.stack([ax, ay], axis=-1)
        if kind == "velocity":  # the body velocities turned to north, east (eq. 8)
            u, v, c, s = x[..., U], x[..., V], np.cos(x[..., PSI]), np.sin(x[..., PSI])
            ne = (u * c - v * s, u * s + v * c)
            return np.array(ne) if x.ndim == 1 else np.stack(ne, axis=-1)
        raise KeyError(kind)

    def H(self, kind: str, x: np.ndarray) -> np.ndarray:
        n = self.n
        Hm = H_state(kind, n)
        if Hm is not None:
            return Hm
        if kind == "accel":
            u, v, r = x[U], x[V], x[R]
            Hm = np.zeros((2, n))
            Hm[0, V], Hm[0, R], Hm[0, AU] = -r, -v, 1.0
            Hm[1, U], Hm[1, R], Hm[1, AV] = r, u, 1.0
            if self.bias:
                Hm[0, BX] = Hm[1, BY] = 1.0
        elif kind == "velocity":
            u, v, c, s = x[U], x[V], np.cos(x[PSI]), np.sin(x[PSI])
            Hm = np.zeros((2, n))
            Hm[0, U], Hm[0, V], Hm[0, PSI] = c, -s, -u * s - v * c
            Hm[1, U], Hm[1, V], Hm[1, PSI] = s, c, u * c - v * s
        else:
            raise KeyError(kind)
        return Hm

    # -- between the state and the world -------------------------------------------------
    def from_motion(self, pn: float, pe: float, vn: float, ve: float, psi: float, r: float) -> np.ndarray:
        """The state of a vessel at (pn, pe) moving at (vn, ve) over ground, heading ψ,
        turning at r, accelerations (and biases) zero: eqs. (15), (18), (19)."""
        x = np.zeros(self.n)
        c, s = np.cos(psi), np.sin(psi)
        x[0], x[1] = pn, pe
        x[U] = vn * c + ve * s  # eq. (18)
        x[V] = -vn * s + ve * c  # eq. (19)
        x[PSI], x[R] = psi, r
        return x

    def from_motion_jacobian(self, vn: float, ve: float, psi: float) -> np.ndarray:
        """∂x/∂(pn, pe, vn, ve, ψ, r): how the errors of the starting values spread into
        the state (for P0)."""
        c, s = np.cos(psi), np.sin(psi)
        J = np.zeros((self.n, 6))
        J[0, 0] = J[1, 1] = 1.0
        J[U, 2], J[U, 3], J[U, 4] = c, s, -vn * s + ve * c
        J[V, 2], J[V, 3], J[V, 4] = -s, c, -vn * c - ve * s
        J[PSI, 4] = J[R, 5] = 1.0
        return J

    def ground_velocity(self, x: np.ndarray) -> tuple[float, float]:
        """(v_n, v_e) over ground."""
        c, s = np.cos(x[PSI]), np.sin(x[PSI])
        return float(x[U] * c - x[V] * s), float(x[U] * s + x[V] * c)

    def body(self, x: np.ndarray) -> np.ndarray:
        """[u, v, a_u, a_v]: the output's body-axis quantities."""
        return np.array([x[U], x[V], x[AU], x[AV]])

    def body_jacobian(self, x: np.ndarray) -> np.ndarray:
        J = np.zeros((4, self.n))
        J[0, U] = J[1, V] = J[2, AU] = J[3, AV] = 1.0
        return J

    def body_var(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """The variances of `body` (diag J P Jᵀ): its quantities are states, so P's own."""
        return P.diagonal()[[U, V, AU, AV]]

    def shift(self, x: np.ndarray, dn: float, de: float) -> None:
        """Move the position states by (dn, de) metres (the plane's origin moved)."""
        x[..., 0] -= dn
        x[..., 1] -= de
