"""Fixed-step fourth-order Runge–Kutta integration of the ship model, chunk by chunk.

The integrator keeps its state between chunks, so a three-hour run (or the live demo,
which never ends) is simulated in pieces of bounded memory with the same result as one
long run. Each chunk returns the grid, the states and their derivatives at the grid
points (RK4's first stage, free), which is what cubic Hermite interpolation needs to
give the state at any sensor's own sampling instant to the integrator's own order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .helm import Helm
from .ship import N_STATE, ShipParticulars, derivative


@dataclass(frozen=True)
class Trace:
    """One chunk on the integration grid; rows are grid points, both ends included."""

    t: np.ndarray  #: s since the start of the run
    s: np.ndarray  #: (n, N_STATE) states
    f: np.ndarray  #: (n, N_STATE) derivatives
    orders: np.ndarray  #: (n, 2) rudder command, thrust speed in force after each point

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])

    def locate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Grid interval index and fraction (0..1) of each time in t."""
        x = (np.asarray(t, dtype=float) - self.t[0]) / self.dt
        i = np.clip(np.floor(x).astype(np.int64), 0, self.t.size - 2)
        return i, x - i

    def hermite(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """States and derivatives at times t (cubic Hermite / linear respectively)."""
        i, tau = self.locate(t)
        tau = tau[:, None]
        h = self.dt
        s0, s1, f0, f1 = self.s[i], self.s[i + 1], self.f[i], self.f[i + 1]
        t2, t3 = tau * tau, tau * tau * tau
        s = (
            (2 * t3 - 3 * t2 + 1) * s0
            + (t3 - 2 * t2 + tau) * h * f0
            + (-2 * t3 + 3 * t2) * s1
            + (t3 - t2) * h * f1
        )
        return s, f0 + tau * (f1 - f0)


class Integrator:
    """The vessel's state advanced under a helm, chunk after chunk."""

    def __init__(self, ship: ShipParticulars, helm: Helm, dt: float, heading_deg: float, speed: float) -> None:
        self.ship = ship
        self.helm = helm
        self.dt = dt
        self.step_index = 0
        self.s: tuple[float, ...] = (0.0, 0.0, speed, 0.0, math.radians(heading_deg), 0.0, 0.0)

    @property
    def t(self) -> float:
        return self.step_index * self.dt

    def advance(self, t_end: float) -> Trace:
        """Integrate to the first grid point at or after t_end."""
        n = max(1, int(math.ceil(t_end / self.dt - 1e-9)) - self.step_index)
        ship, dt, helm = self.ship, self.dt, self.helm
        states, derivs, orders = [], [], []
        s = self.s
        i0 = self.step_index
        for j in range(n):
            t = (i0 + j) * dt
            dc, ut = helm.orders(t, s[4])
            k1 = derivative(s, dc, ut, ship)
            k2 = derivative([a + 0.5 * dt * b for a, b in zip(s, k1)], dc, ut, ship)
            k3 = derivative([a + 0.5 * dt * b for a, b in zip(s, k2)], dc, ut, ship)
            k4 = derivative([a + dt * b for a, b in zip(s, k3)], dc, ut, ship)
            states.append(s)
            derivs.append(k1)
            orders.append((dc, ut))
            s = tuple(a + dt / 6.0 * (b + 2.0 * c + 2.0 * d + e) for a, b, c, d, e in zip(s, k1, k2, k3, k4))
        self.s = s
        self.step_index = i0 + n
        # The end point's derivative under the orders the helm gives there.
        dc, ut = helm.orders(self.t, s[4])
        states.append(s)
        derivs.append(derivative(s, dc, ut, ship))
        orders.append((dc, ut))
        t = (i0 + np.arange(n + 1)) * dt
        arr = np.array(states).reshape(-1, N_STATE)
        return Trace(t, arr, np.array(derivs).reshape(-1, N_STATE), np.array(orders))
