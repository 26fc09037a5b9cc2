"""Where the ship will be: the model itself run ahead from the estimate (seed 002's
"advanced ship predictor").

The state and its covariance are propagated with the filter's own model (RK4, the
linearised transition for P, the process noise density Q_c) to each horizon. Holding
the accelerations constant for minutes diverges (a ship does not keep accelerating):
in the predictor they decay as a_i(t) = a_i(0)·e^(−t/τ) (ESTIMATORS.md §2), while the
turn rate is held: a ship on a constant rudder settles into a steady turn (the yaw
acceleration state, when the model has one, starts the run at 0: it is the wave's).

The 1-σ ellipse of each predicted position comes from its 2 × 2 covariance: the axes
are the square roots of its eigenvalues, the angle the major axis's direction from
north, clockwise, in [0, π). Its size is then calibrated on the ship's own track
(`calibrate.py`): minutes ahead the covariance is mostly the configured process noise
propagated, a guess for any vessel.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np

from edged.angles import wrap_2pi

from .model import PSI, rk4_step, transition

#: Indices of the two acceleration states (a_u, a_v or a_t, a_n) in both models.
ACC = (6, 7)


def ellipse(Pxy: np.ndarray) -> tuple[float, float, float]:
    """(σ_major, σ_minor, angle of the major axis from north, clockwise, rad)."""
    w, vecs = np.linalg.eigh(0.5 * (Pxy + Pxy.T))
    w = np.maximum(w, 0.0)
    major = vecs[:, 1]
    angle = math.atan2(major[1], major[0]) % math.pi
    return math.sqrt(w[1]), math.sqrt(w[0]), angle


class Predictor:
    """Runs a model ahead to fixed horizons; one per estimator core."""

    def __init__(self, model: Any, horizons: tuple[float, ...], decay: float, max_step: float = 20.0) -> None:
        self.model = model
        self.horizons = tuple(sorted(h for h in horizons if h > 0))
        self.decay = decay
        self.max_step = max_step

    def _f(self, x: list[float]) -> list[float]:
        """The model's f with the accelerations decaying (one state, as `transition` gives it)."""
        d = self.model.f(x)
        for i in ACC:
            d[i] -= x[i] / self.decay
        return d

    def _F(self, x: list[float]) -> np.ndarray:
        A = self.model.F(x)
        for i in ACC:
            A[i, i] -= 1.0 / self.decay
        return A

    def _steps(self) -> list[tuple[float, float | None]]:
        """The run's steps (s), each with the horizon it ends at (None: between two):
        10 s steps to 30 s, then 20 s (RK4's relative error at 20 s and 0.03 rad/s of
        turn, 0.6 rad a step, is below 1e-3)."""
        out: list[tuple[float, float | None]] = []
        t = 0.0
        for hz in self.horizons:
            n = len(out)
            while t < hz - 1e-9:
                step = min(hz - t, 10.0 if t < 30.0 else self.max_step)
                t += step
                out.append((step, None))
            out[-1:] = [(out[-1][0], hz)] if len(out) > n else [out[-1], (0.0, hz)]  # 0: a horizon twice
        return out

    def run(self, x: np.ndarray, P: np.ndarray, Qc: np.ndarray) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """[(horizon, x, P)] for each horizon."""
        out = []
        x = np.array(x, dtype=float)
        P = np.array(P, dtype=float)
        i = self.model.yaw.index
        if i is not None:
            # The turn rate held, not the wave's yaw acceleration carried on: its value,
            # its variance and its noise alike. Left in, its noise (a wave's, adapted to
            # ~0.04 rad²/s⁵) integrated into the turn rate as a random walk, and the
            # heading's variance with it: a 120-s ellipse of 10⁸ m across the track.
            x[i] = 0.0
            P[i, :] = 0.0
            P[:, i] = 0.0
            Qc = np.array(Qc, dtype=float)
            Qc[i, :] = 0.0
            Qc[:, i] = 0.0
        for step, hz in self._steps():
            if step > 0.0:
                x, phi = transition(self._F, self._f, x, step, step)
                P = phi @ P @ phi.T + Qc * step
            if hz is not None:
                x[PSI] = wrap_2pi(x[PSI])
                out.append((hz, x.copy(), P.copy()))
        return out

    def states(self, x: np.ndarray) -> list[np.ndarray]:
        """`run`'s x at each horizon, without its covariance (the same floats)."""
        out = []
        xs = np.array(x, dtype=float).tolist()
        if self.model.yaw.index is not None:
            xs[self.model.yaw.index] = 0.0  # the turn rate held (`run`)
        for step, hz in self._steps():
            if step > 0.0:
                xs = rk4_step(self._f, xs, step)[0]
            if hz is not None:
                xs[PSI] = wrap_2pi(xs[PSI])
                out.append(np.array(xs))
        return out

    def predicted(self, runs: list[tuple[float, np.ndarray, np.ndarray]],
                  to_geodetic: Callable[[float, float], tuple[float, float]],
                  scales: Sequence[float] | None = None) -> list[dict[str, float]]:
        """The `predicted` list of `est/manoeuvre` (DESIGN §6) from `run`'s output, each
        ellipse's axes multiplied by its horizon's scale (`calibrate.py`), and by more
        if that would make it smaller than a shorter horizon's: uncertainty does not
        shrink with time."""
        rows = []
        last_major = 0.0
        for i, (hz, xh, Ph) in enumerate(runs):
            lat, lon = to_geodetic(float(xh[0]), float(xh[1]))
            major, minor, angle = ellipse(Ph[0:2, 0:2])
            k = 1.0 if scales is None else float(scales[i])
            if major * k < last_major and major > 0.0:
                k = last_major / major
            last_major = major * k
            rows.append({"dt": hz, "lat": lat, "lon": lon, "heading": float(xh[PSI]),
                         "std_major": major * k, "std_minor": minor * k, "std_angle": angle})
        return rows
