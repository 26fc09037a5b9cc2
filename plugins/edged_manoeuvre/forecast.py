"""The estimate's `predicted` rows: the model's prediction per horizon (`predict.py`),
its position and heading blended with simpler candidates (`blend.py`), its ellipse
sized on the fixes that came due (`calibrate.py`).

The predictions each horizon chooses among: the model with its yaw rate held, the
model with the yaw rate low-passed (`wave_yaw.R_LF_TAU`: the turn that moves the
track, not the wave yaw), a straight line from the estimate at its velocity over
ground, the last fix carried on at the fixes' own velocity over the last
`track.TRACK_SPAN` s (smoother than a receiver's SOG, which has spikes), and dead
reckoning from the last fix at the GNSS's own SOG/COG (at the fixes' velocity when it
sends none).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from edged.angles import wrap_2pi
from edged.geo import LocalPlane

from .blend import ForecastBlend
from .calibrate import EllipseCalibration
from .cmm import Cmm
from .config import ManoeuvreConfig
from .ctra import Ctra
from .model import PSI, R
from .predict import Predictor

CANDIDATES = ("model", "model_low_rate", "straight", "track", "dead_reckoning")
#: SOG/COG older than this (s) no longer carries the dead reckoning.
VG_MAX_AGE = 5.0
#: The share of a fix's own noise (its learned R) the ellipse's calibration takes
#: off (`calibrate.py`): 0, the ellipse is sized to hold the fixes themselves, which
#: is what a navigator, a CPA check or an independent check compares it with (sized to
#: hold the truth behind them, it held 64–76 % of Aava's and Zeus2's fixes at 10 s).
WITNESS_NOISE = 0.0

Row = dict[str, float]


class Anchors(NamedTuple):
    """What the candidates other than the model start from: the low-passed yaw rate,
    the last fix taken (t, lat, lon), the fixes' own velocity (n, e) and the GNSS's
    SOG/COG (t, v_n, v_e). (A named tuple: one is made at every estimate.)"""

    r_lf: float | None
    raw_fix: tuple[float, float, float] | None
    track_velocity: tuple[float, float] | None
    vg: tuple[float, float, float] | None


class Forecast:
    """The prediction rows, their blends and their ellipses' calibration."""

    def __init__(self, cfg: ManoeuvreConfig, model: Ctra | Cmm) -> None:
        self.cfg = cfg
        self.model = model
        self.predictor = Predictor(model, tuple(cfg.horizons), cfg.accel_decay)
        self.calibration = [EllipseCalibration(h, cfg.ellipse_window, sigmas=cfg.ellipse_sigmas)
                            for h in self.predictor.horizons]
        window = cfg.ellipse_window if cfg.ellipse_window > 0.0 else 600.0
        self.blends = [ForecastBlend(h, CANDIDATES, "dead_reckoning", window) for h in self.predictor.horizons]
        self._made: tuple[float, list[Row]] | None = None

    def rows(self, t: float, x: np.ndarray, P: np.ndarray, Qc: np.ndarray, plane: LocalPlane,
             anchors: Anchors) -> list[Row]:
        """The prediction rows, made afresh at most `predict_rate` times a second of data
        time; in between, the last rows with `dt` counted from this estimate's time. Each
        is also kept to size its ellipse when it comes due (`witness`)."""
        rate = self.cfg.predict_rate
        made = self._made
        if made is None or rate <= 0.0 or t - made[0] >= 1.0 / rate - 1e-6 or t < made[0]:
            runs = self.predictor.run(x, P, Qc)
            rows = self.predictor.predicted(runs, plane.to_geodetic, [c.scale for c in self.calibration])
            if self.cfg.mode != "paper":  # the paper's predictor is the model alone
                self._blend(t, x, P, Qc, plane, runs, rows, anchors)
            if self.cfg.ellipse_window > 0.0:
                for c, (_, _, Ph), row in zip(self.calibration, runs, rows):
                    c.add(t, row["lat"], row["lon"], Ph[0:2, 0:2])
            self._made = made = (t, rows)
        age = t - made[0]
        if age == 0.0:
            return made[1]
        return [{**row, "dt": round(row["dt"] - age, 6)} for row in made[1]]

    def _blend(self, t: float, x: np.ndarray, P: np.ndarray, Qc: np.ndarray, plane: LocalPlane, runs: list,
               rows: list[Row], anchors: Anchors) -> None:
        """Each row's position and heading from its horizon's blend of the candidates
        (`blend.py`); the ellipse stays the model's, sized on the blend's own errors."""
        x_lf = np.array(x, dtype=float)
        if anchors.r_lf is not None:
            x_lf[R] = anchors.r_lf
        states_lf = self.predictor.states(x_lf)  # its positions and headings only
        fix = anchors.raw_fix
        if fix is not None and t - fix[0] <= self.cfg.reset_after:
            t_fix, lat0, lon0 = fix
            n0, e0 = plane.to_ne(lat0, lon0)
        else:
            t_fix, n0, e0 = t, float(x[0]), float(x[1])
        vf = self.model.ground_velocity(x)
        vt = anchors.track_velocity or vf
        vg = anchors.vg
        if vg is not None and t - vg[0] <= VG_MAX_AGE:
            vn, ve = vg[1], vg[2]
        else:
            vn, ve = vt
        psi0 = float(x[PSI])
        for b, row, (_, x_m, _), x_l in zip(self.blends, rows, runs, states_lf):
            ahead = t + b.horizon - t_fix
            lat_l, lon_l = plane.to_geodetic(float(x_l[0]), float(x_l[1]))
            lat_s, lon_s = plane.to_geodetic(float(x[0]) + vf[0] * b.horizon, float(x[1]) + vf[1] * b.horizon)
            lat_t, lon_t = plane.to_geodetic(n0 + vt[0] * ahead, e0 + vt[1] * ahead)
            lat_d, lon_d = plane.to_geodetic(n0 + vn * ahead, e0 + ve * ahead)
            cands = np.array([[row["lat"], row["lon"]], [lat_l, lon_l], [lat_s, lon_s], [lat_t, lon_t], [lat_d, lon_d]])
            b.add(t, cands)
            row["lat"], row["lon"] = b.combine(cands)
            w = b.weights
            headings = np.array([float(x_m[PSI]), float(x_l[PSI]), psi0, psi0, psi0])
            row["heading"] = float(wrap_2pi(math.atan2(float(w @ np.sin(headings)), float(w @ np.cos(headings)))))

    def witness(self, t: float, plane: LocalPlane, z: np.ndarray, x: np.ndarray, R_: np.ndarray) -> None:
        """A fix (z, its noise R_) against the predictions due by now: an independent
        witness (the filter's own later estimate shares its errors: measured, it shrank
        the 10-s ellipse to hold 30 % of the truths)."""
        if self.cfg.ellipse_window <= 0.0:
            return
        v_ne = self.model.ground_velocity(x)
        for c in self.calibration:
            c.due(t, plane.to_ne, (float(z[0]), float(z[1])), v_ne, WITNESS_NOISE * R_)
        for b in self.blends:
            b.due(t, plane.to_ne, (float(z[0]), float(z[1])), v_ne)

    def forget_pending(self) -> None:
        """The filter starts again: predictions not yet due are the old filter's."""
        for c in self.calibration:
            c.forget_pending()
        for b in self.blends:
            b.forget_pending()

    def report(self) -> dict[str, Any]:
        """Health's `ellipse_scale` and `prediction` (per horizon)."""
        return {"ellipse_scale": {f"{c.horizon:g}": round(c.scale, 3) for c in self.calibration},
                "prediction": {f"{b.horizon:g}": b.report() for b in self.blends}}
