"""How the filter starts: a position, a velocity over ground and the heading, with P0.

The plane's origin is the first fix; the filter starts once a heading is known and,
in `tuned` mode, `init_window` seconds of fixes give the velocity by a straight-line
fit (σ of the fit in P0), or in `paper` mode the first two fixes by two-point
differencing with P0 of eqs. (20)–(22). A GNSS with a fix every 10–60 s starts from its
last fix and its own SOG/COG, or its last two fixes (`Start.slow_motion`).

`Start` keeps what a start takes (one receiver's recent fixes, the last heading and
rate of turn) and says when it has enough (`Start.motion`); `initial_state` makes the
state and P0 from it, `make_filter` the configured filter.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from edged.angles import wrap_2pi

from .cmm import Cmm
from .config import DEG, ManoeuvreConfig
from .ctra import Ctra
from .filter import KalmanFilter
from .model import PSI

#: A heading or yaw rate older than this does not start the filter.
START_AGE = 1.0
#: 1-σ of a start's velocity from the GNSS's own SOG/COG (m/s per axis): its Doppler
#: velocity's few cm/s, with room for a receiver's lag and COG's noise at low speed. It
#: replaces the line through the fixes when that line's slope is twice as uncertain.
START_VG_SIGMA = 0.2
#: The starting line is fitted to fixes of at most this many seconds (a 1 Hz GNSS:
#: its last three within it).
START_SPAN = 10.0
#: 1-σ of the starting accelerations (m/s²) and biases (m/s²), and of the yaw rate
#: when no rate sensor has spoken (rad/s).
START_ACCEL_SIGMA = 0.1
START_BIAS_SIGMA = 0.05
#: σ of the yaw acceleration at a start (rad/s², ~6 °/s²: a yacht's wave yaw).
START_YAW_ACCEL_SIGMA = 0.1
START_RATE_SIGMA = 0.01
#: Two fixes at least START_SPAN / 2 and at most this far apart (s) start a filter
#: whose GNSS is slow (nearer, their difference is too noisy a velocity).
SLOW_START_SPAN = 60.0

#: (t, v_n, v_e) of the GNSS's own SOG/COG.
GroundVelocity = tuple[float, float, float]


@dataclass(frozen=True)
class Motion:
    """What a start is made from: a position (n, e) and velocity over ground at the
    start's time, the heading, the variances of position and velocity per axis and
    their covariance."""

    pos: tuple[float, float]
    vn: float
    ve: float
    psi: float
    var_p: float
    var_v: float
    cov_pv: float


class Start:
    """What a start takes, gathered while no filter runs."""

    def __init__(self, cfg: ManoeuvreConfig) -> None:
        self.cfg = cfg
        #: (t, p_n, p_e) of one receiver's fixes since the filter stopped.
        self.fixes: deque[tuple[float, float, float]] = deque()
        self.fixes_source: str | None = None
        #: (t, value) of the last heading and rate of turn heard.
        self.heading: tuple[float, float] | None = None
        self.rate: tuple[float, float] | None = None

    def add_fix(self, t: float, pn: float, pe: float, source: str) -> None:
        if self.fixes_source != source:  # a start fits one receiver's fixes, never a mix
            self.fixes.clear()
            self.fixes_source = source
        self.fixes.append((t, pn, pe))

    def motion(self, t: float, vg: GroundVelocity | None) -> Motion | None:
        """The start's motion at t when the fixes and a recent heading give it: the
        paper's last two fixes, the line through the last `init_window` s of fixes (or
        the last three when the GNSS is slower than that, within START_SPAN), or a slow
        receiver's (`slow_motion`)."""
        fixes = self.fixes
        window = float(self.cfg.init_window)
        while len(fixes) > 3 and fixes[0][0] < t - max(window, START_SPAN):
            fixes.popleft()
        hd = self.heading
        if hd is None or t - hd[0] > START_AGE:
            return None
        if window <= 0.0:  # the paper: the last two fixes
            return self._two_fixes(hd[1])
        recent = [f for f in fixes if f[0] >= t - START_SPAN]
        if len(recent) < 3:
            return self.slow_motion(t, hd[1], vg)  # a receiver slower than 3 fixes in START_SPAN
        return self._line(t, hd[1], recent, window, vg)

    def _two_fixes(self, psi: float) -> Motion | None:
        fixes = self.fixes
        if len(fixes) < 2 or fixes[-1][0] - fixes[-2][0] <= 0.0:
            return None
        (t0, n0, e0), (t1, n1, e1) = fixes[-2], fixes[-1]
        dt = t1 - t0
        var_p = float(self.cfg.position_sigma) ** 2
        return Motion((n1, e1), (n1 - n0) / dt, (e1 - e0) / dt, psi, var_p, 2.0 * var_p / dt**2, var_p / dt)

    def _line(self, t: float, psi: float, recent: list[tuple[float, float, float]], window: float,
              vg: GroundVelocity | None) -> Motion | None:
        """The line through the fixes since `init_window` s ago (at least the last
        three), its value and slope at t the position and velocity."""
        since = min(t - window, recent[-3][0])
        pts = [f for f in recent if f[0] >= since]
        span = pts[-1][0] - pts[0][0]
        slow = recent[-1][0] - recent[-3][0] >= window  # three fixes take the window or more
        if span <= 0.0 or (span < 0.5 * window and not slow):
            return None
        ts = np.array([p[0] for p in pts]) - t
        tm = ts.mean()
        sxx = float(((ts - tm) ** 2).sum())
        var_p = float(self.cfg.position_sigma) ** 2
        fit = [np.polyfit(ts, np.array([p[i] for p in pts]), 1) for i in (1, 2)]
        vn, ve = float(fit[0][0]), float(fit[1][0])
        pos = (float(fit[0][1]), float(fit[1][1]))  # the line at t
        # the line's value and slope at t: var a = σ²(1/n + t̄²/Sxx), var b = σ²/Sxx,
        # cov(a, b) = −σ² t̄/Sxx
        var_v = var_p / sxx
        cov_pv = -var_p * tm / sxx
        var_p = var_p * (1.0 / len(pts) + tm * tm / sxx)
        if var_v > (2.0 * START_VG_SIGMA) ** 2 and vg is not None and 0.0 <= t - vg[0] <= START_AGE + 0.5:
            # a slow receiver's line is steep noise (1 Hz, 1.5 m: its slope's σ is
            # 0.75 m/s): the receiver's own velocity (Doppler, a few cm/s) instead
            vn, ve = vg[1], vg[2]
            var_v = START_VG_SIGMA**2
            cov_pv = 0.0
        return Motion(pos, vn, ve, psi, var_p, var_v, cov_pv)

    def slow(self, t: float) -> bool:
        """The receiver is slow: its last two fixes START_SPAN / 2 or more apart, or its
        only one that old (a 10 Hz receiver's first fixes are not a slow receiver's)."""
        fixes = self.fixes
        if len(fixes) >= 2:
            return fixes[-1][0] - fixes[-2][0] >= 0.5 * START_SPAN
        return bool(fixes) and t - fixes[-1][0] >= 0.5 * START_SPAN

    def waits_for_slow(self, t: float) -> bool:
        """A slow receiver's last fix is recent: a start is worth trying at a heading or
        SOG/COG after it, not only at its next fix."""
        fixes = self.fixes
        return bool(fixes) and t - fixes[-1][0] <= SLOW_START_SPAN and self.slow(t)

    def slow_motion(self, t: float, psi: float, vg: GroundVelocity | None) -> Motion | None:
        """A GNSS with a fix every 10–60 s (a ship's receiver thinned to the STW paper's
        30 s) never gives three fixes in START_SPAN: start from the last fix with the
        receiver's own SOG/COG, else from the last two fixes (over 30 s their
        difference is a velocity within 0.07 m/s), the fix carried to now."""
        fixes = self.fixes
        if not fixes or not self.slow(t) or t - fixes[-1][0] > SLOW_START_SPAN:
            return None
        t1, n1, e1 = fixes[-1]
        var_p = float(self.cfg.position_sigma) ** 2
        if vg is not None and abs(vg[0] - t1) <= START_AGE + 0.5:  # the receiver's velocity at its fix
            vn, ve, var_v, cov_pv = vg[1], vg[2], START_VG_SIGMA**2, 0.0
        elif len(fixes) >= 2 and 0.5 * START_SPAN <= t1 - fixes[-2][0] <= SLOW_START_SPAN:
            t0, n0, e0 = fixes[-2]
            dt = t1 - t0
            vn, ve = (n1 - n0) / dt, (e1 - e0) / dt
            var_v, cov_pv = 2.0 * var_p / dt**2, var_p / dt
        else:
            return None
        ahead = t - t1  # the fix carried to now (a heading or SOG/COG after it)
        pos = (n1 + vn * ahead, e1 + ve * ahead)
        var_p, cov_pv = var_p + 2.0 * ahead * cov_pv + ahead * ahead * var_v, cov_pv + ahead * var_v
        return Motion(pos, vn, ve, psi, var_p, var_v, cov_pv)


def initial_state(cfg: ManoeuvreConfig, model: Ctra | Cmm, t: float, m: Motion, rate: tuple[float, float] | None,
                  rng: np.random.Generator | None) -> tuple[np.ndarray, np.ndarray]:
    """x0 and P0 from a start's motion and the last rate of turn, with P0 of eqs.
    (20)–(22): the starting values' errors spread into the state; with `rng` (a
    Monte-Carlo run) x0 is drawn about it, eq. (13)."""
    r = rate[1] if rate is not None and t - rate[0] <= START_AGE else 0.0
    var_r = (float(cfg.yaw_rate_sigma_deg) * DEG) ** 2 if rate is not None else START_RATE_SIGMA**2
    x0 = model.from_motion(m.pos[0], m.pos[1], m.vn, m.ve, m.psi, r)
    C = np.zeros((6, 6))
    C[0, 0] = C[1, 1] = m.var_p
    C[2, 2] = C[3, 3] = m.var_v
    C[0, 2] = C[2, 0] = C[1, 3] = C[3, 1] = m.cov_pv
    C[4, 4] = (float(cfg.heading_sigma_deg) * DEG) ** 2
    C[5, 5] = var_r
    J = model.from_motion_jacobian(m.vn, m.ve, m.psi)
    P0 = J @ C @ J.T
    P0[6, 6] = P0[7, 7] = (float(cfg.accel_sigma) if cfg.mode == "paper" else START_ACCEL_SIGMA) ** 2
    for i in range(8, 10 if model.bias else 8):
        P0[i, i] = START_BIAS_SIGMA**2
    if model.yaw.index is not None:  # seen only through a rate gyro (`ProcessNoise.Q`)
        P0[model.yaw.index, model.yaw.index] = START_YAW_ACCEL_SIGMA**2 if rate is not None else 0.0
    if rng is not None:
        x0 = rng.multivariate_normal(x0, 0.5 * (P0 + P0.T), method="cholesky")
        x0[PSI] = wrap_2pi(x0[PSI])
    return x0, P0


def make_filter(cfg: ManoeuvreConfig, model: Ctra | Cmm, x0: np.ndarray, P0: np.ndarray) -> KalmanFilter:
    """The configured filter (`filter = "ekf" | "ukf" | "enkf"`) started at (x0, P0).

    Imported when first chosen: the UKF brings in filterpy, which an EKF-only
    deployment need not load."""
    if cfg.filter == "ekf":
        from .ekf import Ekf

        return Ekf(model, x0, P0, float(cfg.substep))
    if cfg.filter == "ukf":
        from .ukf import Ukf

        return Ukf(model, x0, P0, float(cfg.substep))
    from .enkf import Enkf

    return Enkf(model, x0, P0, float(cfg.substep), members=cfg.members, seed=cfg.seed, inflation=cfg.inflation)
