"""Seed 000's four-state filter, exactly (`mode = "paper"`), with the log fit beside it.

State x = [d, U_sog, U_stw, U_c]: distance travelled, speed over ground, speed through
water, current along the track (+ following). On the paper's fixed sample time T
(`paper_period`, 30 s), with the total acceleration A = |a| as input:
    d(k+1)     = d(k) + T·U_sog(k) + ½T²·A(k)          (12)
    U_sog(k+1) = U_sog(k) + T·A(k)                      (13)
    U_stw(k+1) = U_sog(k) − U_c(k) + T·A(k)             (14)
    U_c(k+1)   = U_c(k) + v_c                           (15)
    F = [[1, T, 0, 0], [0, 1, 0, 0], [0, 1, 0, −1], [0, 0, 0, 1]],  G = [½T², T, T, 0]ᵀ,
    G_w = [[½T², 0], [T, 0], [T, 0], [0, 1]],  Q = diag(σ_a², σ_c²)            (18)
    z1 = [d, U_sog, U_c] when a forecast arrived, H1 = rows 1, 2, 4 of I;
    z2 = [d, U_sog] otherwise, H2 = rows 1, 2 of I                           (16, 17, 19)
    time update (20)–(21), measurement update (22)–(25), R from Table 1.
The measured d is the sum of the distances between successive fixes taken on the
grid; the forecast enters as the paper assumes it, along the track: its speed, signed
by whether it follows or heads the vessel. The paper's |a| cannot decelerate
(ESTIMATORS.md §1): this mode reproduces the paper, it is not the default.

The Doppler log is fitted beside it, not in it (`dvl.LogCalibration`, as in `vector`
mode, along the course): the paper's four states stay exactly the paper's.
"""

from __future__ import annotations

import math

import numpy as np

from edged.geo import haversine

from .dvl import LogCalibration
from .kalman import innovation, predict, update

D, U_SOG, U_STW, U_C = range(4)
_H1 = np.eye(4)[[D, U_SOG, U_C]]
_H2 = np.eye(4)[[D, U_SOG]]
#: Without a new fix there is no new distance: SOG (and the forecast) alone.
_H_SOG = np.eye(4)[[U_SOG]]
_H_SOG_C = np.eye(4)[[U_SOG, U_C]]
#: A gap in the data longer than this (s) restarts the filter rather than stepping
#: the whole gap on the 30 s grid.
MAX_GAP = 3600.0


def paper_matrices(T: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """F, G and G_w of eq. (18)."""
    F = np.eye(4)
    F[D, U_SOG] = T
    F[U_STW, U_STW] = 0.0
    F[U_STW, U_SOG] = 1.0
    F[U_STW, U_C] = -1.0
    G = np.array([0.5 * T * T, T, T, 0.0])
    Gw = np.zeros((4, 2))
    Gw[D, 0], Gw[U_SOG, 0], Gw[U_STW, 0], Gw[U_C, 1] = 0.5 * T * T, T, T, 1.0
    return F, G, Gw


class PaperFilter:
    """The paper's estimator on its own grid t0 + k·T."""

    def __init__(self, t0: float, sog: float, T: float, sigma_a: float, sigma_c: float,
                 sigma_d: float, sigma_sog: float) -> None:
        self.t = t0
        self.T = T
        self.x = np.array([0.0, sog, sog, 0.0])
        self.P = np.diag([sigma_d**2, sigma_sog**2, 1.0, 1.0])
        self.F, self.G, Gw = paper_matrices(T)
        Q = np.diag([sigma_a**2, sigma_c**2])
        self.GQG = Gw @ Q @ Gw.T
        self.sigma_d = sigma_d
        self.sigma_sog = sigma_sog

    def next_time(self) -> float:
        return self.t + self.T

    def cycle(self, A: float, d: float | None, sog: float, u_c: float | None, var_c: float) -> float:
        """One sample time: time update with input A, then H1 or H2 (without the
        distance row when no new fix came: `d` None). Returns the NIS."""
        self.x, self.P = predict(self.x, self.P, self.F, self.GQG, self.G * A)  # (20), (21)
        self.t += self.T
        rows, zs, rs = [], [], []
        if d is not None:
            zs.append(d)
            rs.append(self.sigma_d**2)
        zs.append(sog)
        rs.append(self.sigma_sog**2)
        if u_c is not None:
            zs.append(u_c)
            rs.append(var_c)
        if d is not None:
            H = _H1 if u_c is not None else _H2
        else:
            H = _H_SOG_C if u_c is not None else _H_SOG
        z, R = np.array(zs), np.diag(rs)
        del rows
        y, S, nis = innovation(self.x, self.P, z, R, H)
        self.x, self.P = update(self.x, self.P, y, S, R, H)  # (22)–(25)
        return nis


class PaperModel:
    """Feeds the paper's filter as the paper does: the latest samples at each T."""

    def __init__(self, cfg) -> None:  # cfg: StwConfig (not imported: no cycle)
        self.cfg = cfg
        self.f: PaperFilter | None = None
        self._fix: tuple[float, float, float] | None = None  # t, lat, lon
        self._used_fix: tuple[float, float, float] | None = None
        self._sog: tuple[float, float, float] | None = None  # t, sog, cog
        self._used_sog_t = -math.inf
        self._A = 0.0
        self._u_c: float | None = None
        self._d = 0.0
        self.last_nis: float | None = None
        self.restarts = 0
        self.log: LogCalibration | None = None

    @property
    def ready(self) -> bool:
        return self.f is not None

    def advance(self, t: float) -> list[float]:
        """Run every sample time up to t; the NIS of each update."""
        out = []
        f = self.f
        if f is not None and t - f.t > MAX_GAP:
            # Hours without data: the paper's filter starts again at the next SOG.
            self.f = f = None
            self._fix = self._used_fix = self._sog = None
            self._d = 0.0
            self.restarts += 1
        while f is not None and f.next_time() <= t:
            sog = self._sog
            new_fix = self._fix is not None and (self._used_fix is None or self._fix[0] > self._used_fix[0])
            if sog is None or (sog[0] <= self._used_sog_t and not new_fix):
                # Nothing new from the GNSS: the time update (20)-(21) alone.
                f.x, f.P = predict(f.x, f.P, f.F, f.GQG, f.G * self._A)
                f.t += f.T
                continue
            self._used_sog_t = sog[0]
            d = self._distance()
            if d is not None:
                self._d = d
            nis = f.cycle(self._A, d, sog[1], self._u_c, self.cfg.forecast_sigma**2)
            out.append(nis)
            self.last_nis = nis
            self._u_c = None
        return out

    def _distance(self) -> float | None:
        fix, used = self._fix, self._used_fix
        if fix is None or (used is not None and fix[0] <= used[0]):
            return None
        self._used_fix = fix
        if used is None:
            # The first fix starts the distance: d is measured from here on.
            f = self.f
            if f is not None:
                f.x[D] = 0.0
                f.P[D, :] = 0.0
                f.P[:, D] = 0.0
                f.P[D, D] = f.sigma_d**2
            self._d = 0.0
            return None
        return self._d + haversine(used[1], used[2], fix[1], fix[2])

    def position(self, t: float, lat: float, lon: float) -> None:
        self._fix = (t, lat, lon)

    def velocity(self, t: float, sog: float, cog: float) -> None:
        self._sog = (t, sog, cog)
        if self.f is None:
            c = self.cfg
            self.f = PaperFilter(t, sog, c.paper_period, c.accel_sigma, c.paper_sigma_c,
                                 c.position_sigma, c.sog_sigma)
            self._used_sog_t = t
            if self.log is None:
                self.log = LogCalibration(t, c.current_fast_q, c.current_rate_sigma, c.current_prior_sigma,
                                          c.current_sigma_max, c.dvl_scale_prior, c.dvl_fit_scale)

    def accel(self, ax: float, ay: float) -> None:
        self._A = math.hypot(ax, ay)  # the paper's total acceleration |a|

    def forecast(self, t: float, set_rad: float, drift: float) -> None:
        cog = self._sog[2] if self._sog is not None else set_rad
        self._u_c = drift if math.cos(set_rad - cog) >= 0.0 else -drift
        if self.log is not None:
            self.log.forecast(t, drift * math.cos(set_rad), drift * math.sin(set_rad), self.cfg.forecast_sigma**2)

    def dvl(self, t: float, z: float, gate: float, dry: bool = False) -> tuple[float | None, bool]:
        """The log against the ground speed along the course and the log fit's current."""
        if self.log is None or self._sog is None:
            return None, False
        _, sog, cog = self._sog
        ahead = np.array([math.cos(cog), math.sin(cog)])
        var = self.cfg.dvl_sigma**2 + self.cfg.sog_sigma**2
        return self.log.reading(t, z, ahead, sog * ahead, var, gate, dry)

    def ground_std(self, t: float) -> float:
        """1-σ of the filter's SOG (m/s)."""
        if self.f is None:
            return math.inf
        return math.sqrt(max(float(self.f.P[U_SOG, U_SOG]), 0.0))

    def estimate(self, t: float) -> dict | None:
        f = self.f
        if f is None:
            return None
        x, P = f.x, f.P
        out = {
            "stw": float(x[U_STW]),
            "stw_std": math.sqrt(max(P[U_STW, U_STW], 0.0)),
            "sog": float(x[U_SOG]),
            "current": abs(float(x[U_C])),
            "distance": float(x[D]),
            "stw_long": None,
            "stw_trans": None,
            "current_set": None,
            "current_along": float(x[U_C]),
        }
        if self.log is not None:
            out.update(self.log.values())
        return out
