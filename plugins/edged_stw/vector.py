"""`mode = "vector"`: STW = ground velocity − current, as vectors (ESTIMATORS.md §1).

The ground motion (`ground.GroundFilter`) comes from GNSS and the IMU; the current and
the leeway (`current.CurrentFilter`) from forecasts and from heading vs course; the
log's offset (`dvl.LogCalibration`) from the log against its own copy of the current,
which never flows back. Their errors are independent to first order
(different sensors), so the STW covariance is the sum of the two 2×2 blocks:
    w = v_g − c,  P_w = P_v + P_c,  STW = |w|,  σ_STW² = ŵᵀ P_w ŵ
    stw_long = w·x̂,  stw_trans = w·ŷ   (x̂ ahead, ŷ to starboard, from the heading)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

try:  # what np.linalg.eigvalsh calls, without its checks (see kalman.py)
    from numpy.linalg._umath_linalg import eigvalsh_lo as _eigvalsh_lo
except ImportError:  # pragma: no cover
    _eigvalsh_lo = np.linalg.eigvalsh

from .config import StwConfig
from .current import C, CurrentFilter, CurrentParams
from .dvl import LogCalibration
from .ground import VEL, GroundFilter
from edged.geo import LocalPlane

#: Re-anchor the local plane after this many metres (plane.py).
ANCHOR_RADIUS = 2000.0
#: Heading vs course at most every this many seconds: successive ground velocities are
#: correlated through the filter, and one look every 10 s is plenty for a current.
CROSS_INTERVAL = 10.0
#: Variance floor of a 1 s mean acceleration: waves and vibration the model cannot follow.
ACCEL_FLOOR_VAR = 0.01**2
#: Gate (χ², 2 dof, 99.99 %) for averaged accelerations and (1 dof) for the log.
ACCEL_GATE = 18.4
DVL_GATE = 25.0
#: Gate (χ², 1 dof, 99.9 %) for heading vs course.
CROSS_GATE = 10.83


def unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def _worst_std(P: np.ndarray) -> float:
    """1-σ of the ground velocity along its worst axis: √ of the largest eigenvalue of
    P_v (LAPACK's, through numpy's ufunc, as np.linalg.eigvalsh gives it)."""
    return math.sqrt(max(float(_eigvalsh_lo(P[VEL, VEL])[-1]), 0.0))


class VectorModel:
    def __init__(self, cfg: StwConfig) -> None:
        self.cfg = cfg
        self.plane: LocalPlane | None = None
        self.ground: GroundFilter | None = None
        self.current: CurrentFilter | None = None
        self.log: LogCalibration | None = None
        self.distance = 0.0
        self._last_cross = -math.inf
        self.dvl_updates = 0

    @property
    def ready(self) -> bool:
        return self.ground is not None

    def _start(self, t: float, v_n: float, v_e: float, sigma: float) -> None:
        c = self.cfg
        self.ground = GroundFilter(t, v_n, v_e, sigma, c.jerk_density)
        self.current = CurrentFilter(t, CurrentParams(
            c.current_steady_q, c.current_slow_q, c.current_fast_q, c.current_rate_sigma, c.current_switch,
            c.current_prior_sigma, c.current_sigma_max, c.leeway_sigma, c.leeway_time,
        ))
        self.log = LogCalibration(t, c.current_fast_q, c.current_rate_sigma, c.current_prior_sigma,
                                  c.current_sigma_max, c.dvl_scale_prior, c.dvl_fit_scale)

    def _advance(self, t: float) -> None:
        g = self.ground
        assert g is not None
        if t > g.t:
            self.distance += GroundFilter.speed(g.x) * (t - g.t)
        g.predict(t)

    # --- measurements: each returns (nis, used); nis None when not gated ---
    def position(self, t: float, lat: float, lon: float) -> tuple[float | None, bool]:
        if self.plane is None:
            self.plane = LocalPlane(lat, lon)
        if self.ground is None:
            # Only positions so far: the velocity comes from them (σ 10 m/s to start).
            self._start(t, 0.0, 0.0, 10.0)
        g = self.ground
        assert g is not None
        n, e = self.plane.to_ne(lat, lon)
        self._advance(t)
        nis, used = g.try_position(n, e, self.cfg.position_sigma, self.cfg.gnss_gate)
        if used and math.hypot(g.x[0], g.x[1]) > ANCHOR_RADIUS:
            lat0, lon0 = self.plane.to_geodetic(float(g.x[0]), float(g.x[1]))
            g.shift(float(g.x[0]), float(g.x[1]))
            self.plane = LocalPlane(lat0, lon0)
        return nis, used

    def reset_position(self, lat: float, lon: float) -> None:
        assert self.plane is not None and self.ground is not None
        n, e = self.plane.to_ne(lat, lon)
        self.ground.reset_position(n, e, self.cfg.position_sigma)

    def velocity(self, t: float, v_n: float, v_e: float) -> tuple[float | None, bool]:
        if self.ground is None:
            self._start(t, v_n, v_e, self.cfg.sog_sigma)
            return None, True
        self._advance(t)
        return self.ground.try_velocity(v_n, v_e, self.cfg.sog_sigma, self.cfg.gnss_gate)

    def reset_velocity(self, v_n: float, v_e: float) -> None:
        assert self.ground is not None
        self.ground.reset_velocity(v_n, v_e, self.cfg.sog_sigma)

    def accel(self, t: float, a_n: float, a_e: float, n: int) -> tuple[float | None, bool]:
        if self.ground is None:
            return None, False
        # The mean of the last second's samples, applied now if the filter has moved
        # past the last sample (the acceleration changes little within a second).
        t = max(t, self.ground.t)
        self._advance(t)
        var = self.cfg.accel_sigma**2 / max(n, 1) + ACCEL_FLOOR_VAR
        return self.ground.try_accel(a_n, a_e, var, ACCEL_GATE)

    def cross(self, t: float, heading: float) -> tuple[float, bool] | None:
        """Heading vs course (the caller checked heading is fresh and we are not turning)."""
        g, cur = self.ground, self.current
        if g is None or cur is None or t - self._last_cross < CROSS_INTERVAL:
            return None
        v = g.x[VEL]
        speed = float(math.hypot(*v))
        if speed < self.cfg.min_speed:
            return None
        self._last_cross = t
        stbd = unit(heading + math.pi / 2.0)
        var = float(stbd @ g.P[VEL, VEL] @ stbd) + (math.radians(self.cfg.heading_sigma_deg) * speed) ** 2
        # The sway state also carries a compass misalignment: it scales with speed.
        cur.sway_sigma = math.hypot(self.cfg.leeway_sigma, speed * math.radians(self.cfg.heading_bias_deg))
        return cur.cross(t, float(v @ stbd), stbd, var, CROSS_GATE, g.r)

    def forecast_nis(self, t: float, c_n: float, c_e: float, var: float) -> float:
        assert self.current is not None
        return self.current.forecast_nis(t, c_n, c_e, var)

    def forecast(self, t: float, c_n: float, c_e: float, var: float) -> None:
        assert self.current is not None and self.log is not None
        self.current.forecast(t, c_n, c_e, var)
        self.log.forecast(t, c_n, c_e, var)

    def forget_current(self) -> None:
        assert self.current is not None
        self.current.inflate(self.cfg.current_prior_sigma)

    def dvl(self, t: float, stw_long: float, heading: float | None, dry: bool = False) -> tuple[float | None, bool]:
        """The log into its fit (`dry`: only its gate's verdict, nothing fitted)."""
        g, cur = self.ground, self.current
        if g is None or cur is None:
            return None, False
        v = g.x[VEL]
        ahead = unit(heading) if heading is not None else v / max(float(math.hypot(*v)), 1e-9)
        var = self.cfg.dvl_sigma**2 + float(ahead @ g.P[VEL, VEL] @ ahead)
        assert self.log is not None
        nis, used = self.log.reading(t, stw_long, ahead, v.copy(), var, DVL_GATE, dry)
        self.dvl_updates += used and not dry
        return nis, used

    # --- output ---
    def estimate(self, t: float, heading: float | None) -> dict[str, Any] | None:
        """The published fields at t (the log's own fields included)."""
        res = self._estimate(t, heading)
        return None if res is None else res[0]

    def publishable(self, t: float, heading: float | None) -> tuple[dict[str, Any], float] | None:
        """`estimate` and `ground_std` at t from one prediction of the ground filter
        (a tick asks for both)."""
        res = self._estimate(t, heading)
        if res is None:
            return None
        out, P = res
        return out, _worst_std(P)

    def _estimate(self, t: float, heading: float | None) -> tuple[dict[str, Any], np.ndarray] | None:
        g, cur = self.ground, self.current
        if g is None or cur is None:
            return None
        x, P = g.predicted(t)
        y, Pc = cur.mixture(t)
        v = x[VEL]
        c = y[C]
        w = v - c
        Pw = P[VEL, VEL] + Pc[C, C]
        stw = float(math.hypot(w[0], w[1]))
        if stw > 0.1:
            j = w / stw
            stw_var = float(j @ Pw @ j)
        else:
            stw_var = float(np.trace(Pw))
        sog = float(math.hypot(v[0], v[1]))
        track = v / sog if sog > 0.1 else None
        ahead = unit(heading) if heading is not None else track
        out: dict[str, Any] = {
            "stw": stw,
            "stw_std": math.sqrt(max(stw_var, 0.0)),
            "sog": sog,
            "current": float(math.hypot(c[0], c[1])),
            "distance": self.distance + sog * max(0.0, t - g.t),
            "stw_long": None if ahead is None else float(w @ ahead),
            "stw_trans": None if ahead is None else float(w @ np.array([-ahead[1], ahead[0]])),
            "current_set": math.atan2(c[1], c[0]) % (2.0 * math.pi),
            "current_along": None if track is None else float(c @ track),
        }
        if self.log is not None:
            out.update(self.log.values())
        return out, P

    def ground_std(self, t: float) -> float:
        """1-σ of the ground velocity at t along its worst axis (m/s)."""
        if self.ground is None:
            return math.inf
        _, P = self.ground.predicted(t)
        return _worst_std(P)

    def current_sigma(self) -> float | None:
        if self.current is None:
            return None
        _, P = self.current.mixture()
        return math.sqrt(max(0.5 * (P[0, 0] + P[1, 1]), 0.0))

    def health(self) -> dict[str, Any]:
        if self.current is None:
            return {}
        return {"current_model": {m: round(p, 4) for m, p in self.current.mode_probabilities().items()}}

