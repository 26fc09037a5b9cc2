"""The manoeuvring-state estimator's core: measurements in, `est/manoeuvre` out.

Each measurement is met at its own time: the filter is predicted from its last time
to the measurement's (any interval, Runge–Kutta sub-steps) and updated with that
sensor's rows of h only (seed 002 Table 2, split by sensor). The sensors:
`position` (lat, lon → the local tangent plane), `heading`, `yaw_rate`, `accel_body`
(ax, ay: the accelerometers, Coriolis terms included). `current` measurements, or an
`stw` estimator's `est/<name>`, give the drift angle through the water (seed 001).

Start: the plane's origin is the first fix; the filter starts once a heading is known
and, in `tuned` mode, `init_window` seconds of fixes give the velocity by a straight-
line fit (σ of the fit in P0), or in `paper` mode the first two fixes by two-point
differencing with P0 of eqs. (20)–(22).

Monitoring (seed 002 §4): every update's NIS against its χ² band and rcond(S)
(eq. 23); rcond below 1e-10 is a divergence, and so is a state or covariance that is
not finite or a variance beyond any physical sense (`VAR_MAX`: a one-row S, as a
heading's, always has rcond 1): counted, reported, and the filter starts again from
the next measurements. Gated updates,
released gates, resets and the process-noise scale are in health.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from typing import Any

import numpy as np

from edged.geo import LocalPlane
from edged.units import finite_numbers as _finite
from edged.innovation import InnovationMonitor
from edged.records import Estimate, Measurement

from .adaptive import Gate, NoiseEstimate, QScale, Roughness
from .cmm import Cmm
from .config import DEG, ManoeuvreConfig
from .decimate import Decimator
from .faults import SensorFaults
from .ctra import Ctra
from .model import KINDS, PSI, R, residual, say, wrap_2pi, wrap_pi
from .blend import ForecastBlend
from .calibrate import EllipseCalibration
from .predict import Predictor
from .sources import SourceCopies

#: rcond(S) below this is a diverged filter (seed 002 §4.2).
RCOND_MIN = 1e-10
#: A heading or yaw rate older than this does not start the filter.
START_AGE = 1.0
#: A current older than this (s of data time) no longer gives the drift through the
#: water (a forecast's own validity; the stw estimator publishes every second).
CURRENT_MAX_AGE = 3 * 3600.0
#: 1-σ of a start's velocity from the GNSS's own SOG/COG (m/s per axis): its Doppler
#: velocity's few cm/s, with room for a receiver's lag and COG's noise at low speed. It
#: replaces the line through the fixes when that line's slope is twice as uncertain.
START_VG_SIGMA = 0.2
#: The same lat, lon from one source within this many seconds is one fix told again.
REPEAT_WINDOW = 0.9
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
#: The smallest 1-σ a sensor's learned noise may reach (per row): below any real
#: sensor's, so that the estimate follows a good sensor but never trusts one blindly.
SIGMA_FLOOR = {
    "position": np.full(2, 0.05),
    "heading": np.array([0.005 * DEG]),
    "yaw_rate": np.array([0.0005 * DEG]),
    "accel": np.full(2, 0.001),
    "velocity": np.full(2, 0.005),
}
#: What two good sensors of a kind may differ by (per row), whatever their σ: two
#: compasses by their deviation and the wave yaw one sees first, two GNSS antennas by
#: their lever arm, two rate gyros by their biases. Beyond it (and beyond APART
#: combined σ) two sources disagree and are never averaged (`sources.py`).
DISAGREE_FLOOR = {
    "position": np.full(2, 30.0),
    "heading": np.array([5.0 * DEG]),
    "yaw_rate": np.array([0.5 * DEG]),
    "accel": np.full(2, 0.5),
    "velocity": np.full(2, 2.0),
}
#: The course over ground decides between two disagreeing compasses when the track
#: of the last TRACK_SPAN s is at least TRACK_SPEED m/s and one compass is closer to it
#: than the other by TRACK_MARGIN (a drift angle is a few degrees underway, not 20).
TRACK_SPAN = 10.0
TRACK_SPEED = 1.0
TRACK_MARGIN = 5.0 * DEG
#: A measurement kind whose innovations stay this far above their χ² band over a full
#: window of updates (mean NIS above NIS_PROBLEM_MEAN × dof *and* fewer than
#: NIS_PROBLEM_IN_BAND of them inside the two-sided 95 % band: a few outliers lift the
#: mean alone) is named in health's `problems` (`ok: false`): the filter's model of that
#: sensor is wrong (a fault, a second source nobody separated, a noise beyond what the
#: adaptation may learn).
NIS_PROBLEM_MEAN = 5.0  # × dof
NIS_PROBLEM_IN_BAND = 0.5
NIS_PROBLEM_UPDATES = 50
#: A hull making way over ground faster than SIDEWAYS_SPEED m/s with a drift angle
#: between SIDEWAYS_ANGLE and 180° − SIDEWAYS_ANGLE for SIDEWAYS_SPAN s of data is
#: not possible (leeway is a few degrees; a cross current at this speed turns the track
#: by tens of degrees at most): the heading or the positions are wrong, and health
#: says so (Furuno's log: heading 143°, track 213° at 5.9 m/s).
SIDEWAYS_SPEED = 3.0
SIDEWAYS_ANGLE = 45.0 * DEG
SIDEWAYS_SPAN = 30.0
#: A fix this far from the estimate (m, and JUMP_SIGMAS of its σ) is held out for
#: JUMP_HOLD s before it is taken as the position (`_far`).
JUMP_FAR = 500.0
JUMP_SIGMAS = 10.0
JUMP_HOLD = 120.0
#: The estimate's velocity this far from the GNSS's SOG/COG (m/s, and σ) SOG_OFF_RUN
#: times in a row is a diverged filter; SOG_SIGMA is the receiver's own (m/s).
SOG_OFF = 2.0
SOG_OFF_SIGMAS = 6.0
SOG_OFF_RUN = 5
SOG_SIGMA = 0.2
#: A GNSS position and velocity this close in time (s) are one epoch: both beyond their
#: gates is one story, a manoeuvre the filter missed, not two outliers (`_gnss_gated_both`).
GNSS_EPOCH = 0.5
#: Sensors whose noise is white, so that their readings' own roughness bounds it
#: (`adaptive.Roughness`): rate gyros. Not a GNSS position (its error wanders over
#: seconds: bounded so, its R fell below the truth and its NIS rose to 2.4 per dof),
#: nor a compass (a gyrocompass's error is smooth).
ROUGH_KINDS = frozenset({"yaw_rate"})
#: The NIS adaptation's groups: which states' process noise each scales, and the
#: sensors whose NIS drives it, in order of preference: the first that has updated in
#: the last `DRIVER_SPAN` s drives it alone. Each group listens to the sensor that sees
#: its states most directly: a rudder order shows first in the rate of turn (in the
#: heading when there is no rate sensor), an engine order or a turn's sway in the
#: accelerometers (in the positions without them). Pooling sensors would let a
#: consistent one hide another's inconsistency: a 0.1° heading's NIS barely moves when
#: the yaw noise is ten times too high, a 0.005°/s gyro's does. And the sensor that
#: drives a group does not also have to learn its own noise from the same NIS: the
#: GNSS's is then learned against a process noise the accelerometers have fixed.
GROUPS = {
    "yaw": (("yaw_rate", "heading"), (5,)),
    "translation": (("accel", "velocity", "position"), (2, 3, 6, 7)),
}
DRIVER_SPAN = 5.0
#: Two fixes at least START_SPAN / 2 and at most this far apart (s) start a filter
#: whose GNSS is slow (nearer, their difference is too noisy a velocity).
SLOW_START_SPAN = 60.0
#: A GNSS jump this soon (s) after the start means the start was wrong: start again.
RESTART_SPAN = 20.0
#: The predictions each horizon chooses among (`blend.py`): the model with its yaw
#: rate held, the model with the yaw rate low-passed over R_LF_TAU s (the turn that
#: moves the track, not the wave yaw), a straight line from the estimate at its
#: velocity over ground, the last fix carried on at the fixes' own velocity over the
#: last TRACK_SPAN s (smoother than a receiver's SOG, which has spikes), and dead
#: reckoning from the last fix at the GNSS's own SOG/COG (at the fixes' velocity when
#: it sends none).
CANDIDATES = ("model", "model_low_rate", "straight", "track", "dead_reckoning")
R_LF_TAU = 20.0
#: The time constant (s) of the variance of r about its low-passed value: the wave's yaw.
R_WAVE_TAU = 10.0
#: Seconds without a fix after which a sample-at-a-time accelerometer's R takes in the
#: wave yaw (`_between_fixes`).
SPARSE_FIX = 3.0
#: SOG/COG older than this (s) no longer carries the dead reckoning.
VG_MAX_AGE = 5.0
#: The share of a fix's own noise (its learned R) the ellipse's calibration takes
#: off (`calibrate.py`): 0, the ellipse is sized to hold the fixes themselves, which
#: is what a navigator, a CPA check or an independent check compares it with (sized to
#: hold the truth behind them, it held 64–76 % of Aava's and Zeus2's fixes at 10 s).
WITNESS_NOISE = 0.0
#: Health text of each input's absence.
COSTS = {
    "position": "no GNSS position: the filter cannot start",
    "heading": "no heading: the filter cannot start (sway needs the heading)",
    "yaw_rate": "no rate of turn: r is seen through the heading only",
    "accel_body": "no accelerometers: accelerations are seen through the GNSS only",
}


class ManoeuvreCore:
    def __init__(self, cfg: ManoeuvreConfig, *, init_rng: np.random.Generator | None = None) -> None:
        self.cfg = cfg
        bias = bool(cfg.imu_bias)
        tau = float(cfg.yaw_accel_tau or 0.0)
        self.model: Ctra | Cmm = Ctra(bias, tau) if cfg.model == "ctra" else Cmm(bias, tau)
        yaw = self.model.yaw
        q = [cfg.q_position, cfg.q_position, cfg.q_velocity, cfg.q_velocity, cfg.q_heading,
             cfg.q_yaw_accel, cfg.q_jerk, cfg.jerk_v()] + [cfg.q_bias] * (2 if bias else 0)
        q += [cfg.q_yaw_jerk] * yaw.size
        self.Qc = np.diag(np.asarray(q, dtype=float))
        #: The states whose process noise each adaptation group scales (`_Q`).
        self.group_states = {g: states for g, (_, states) in GROUPS.items()}
        self._gyro_states = {**self.group_states, "yaw": (yaw.index,)} if yaw.index is not None else None
        self.sigma0 = {
            "position": np.full(2, float(cfg.position_sigma)),
            "heading": np.array([float(cfg.heading_sigma_deg) * DEG]),
            "yaw_rate": np.array([float(cfg.yaw_rate_sigma_deg) * DEG]),
            "accel": np.full(2, float(cfg.accel_sigma)),
            "velocity": np.full(2, float(cfg.velocity_sigma)),
        }
        self.inputs = frozenset({"position", "heading", "yaw_rate", "accel_body", "current", "velocity_ground"}
                                | ({f"est/{cfg.current_from}"} if cfg.current_from else set()))
        self.filter: Any = None
        self.t: float | None = None
        #: The time of the last state `tick` published (each is published once).
        self._published_t: float | None = None
        self.plane: LocalPlane | None = None
        # An ensemble's spread is its covariance: lowering the noise that keeps the
        # members apart collapses it, so an EnKF's process noise is only ever raised.
        self.qscales = {g: QScale(min_base=1.0 if cfg.filter == "enkf" else 1e-3) for g in GROUPS}
        self._last_update: dict[str, float] = {}
        self.noise: dict[tuple[str, str], NoiseEstimate] = {}
        self.roughness: dict[tuple[str, str], Roughness] = {}
        self.gates: dict[tuple[str, str], Gate] = {}
        self.monitor = InnovationMonitor(window=200)
        self.predictor = Predictor(self.model, tuple(cfg.horizons), cfg.accel_decay)
        self.calibration = [EllipseCalibration(h, cfg.ellipse_window, sigmas=cfg.ellipse_sigmas) for h in self.predictor.horizons]
        window = cfg.ellipse_window if cfg.ellipse_window > 0.0 else 600.0
        self.blends = [ForecastBlend(h, CANDIDATES, "dead_reckoning", window) for h in self.predictor.horizons]
        self._r_lf: float | None = None  # the yaw rate low-passed (`R_LF_TAU`)
        self._r_lf_t: float | None = None
        self._r_wave_var = 0.0  # variance of r about r_lf (`_low_rate`), rad²/s²
        self._raw_fix: tuple[float, float, float] | None = None  # t, lat, lon of the last fix taken
        self._vg: tuple[float, float, float] | None = None  # t, v_n, v_e of the GNSS's own SOG/COG
        self._vg_source: str | None = None
        self.decimator = Decimator(float(cfg.max_rate))
        self.faults = SensorFaults()
        self._far_since: dict[str, float] = {}  # position source -> first fix far off the track
        self._sog_off = 0  # SOG/COG measurements in a row far from the estimate
        self._gnss_gated: dict[str, float] = {}  # kind → data time of its last gated update
        self.copies = SourceCopies(DISAGREE_FLOOR, self._choose, one_at_a_time=frozenset({"position", "velocity"}))
        self._track: deque[tuple[float, float, float]] = deque()  # (t, p_n, p_e) of the fixes taken
        self.muted: Counter[str] = Counter()
        self.seen: Counter[str] = Counter()
        self.rejected: Counter[str] = Counter()
        self.resets: Counter[str] = Counter()
        self.divergences = 0
        self._fixes: deque[tuple[float, float, float]] = deque()
        self._fixes_source: str | None = None
        self._last_fix: dict[str, tuple[float, Any, Any, float | None]] = {}
        self._heading: tuple[float, float] | None = None
        self._rate: tuple[float, float] | None = None
        self._current: tuple[float, float, float] | None = None  # t, v_n, v_e of the water
        self._nis: float | None = None
        self._rcond: float | None = None
        self._init_rng = init_rng
        self._t_started = -math.inf
        self._t_input: float | None = None  # the newest input's data time
        self._sideways: tuple[float, float, float] | None = None  # since, drift angle, sog
        self._far_what = ""
        self._since_start: Counter[str] = Counter()  # updates applied since the start
        self._prediction: tuple[float, list[dict[str, float]]] | None = None
        #: When a list (the Monte-Carlo harness sets one): (t, kind, NIS, dof, applied,
        #: whitened innovation S^(-1/2) y) of every update, for the paper's tables.
        self.trace: list[tuple[float, str, float, int, bool, np.ndarray]] | None = None

    # ------------------------------------------------------------------ inputs
    def step(self, rec: Measurement | Estimate) -> list[Estimate]:
        if isinstance(rec, Estimate):
            if rec.name == self.cfg.current_from:
                self._on_stw(rec)
            return []
        kind = rec.kind
        v = rec.values
        t = rec.t
        self.seen[kind] += 1
        self._gap(t)
        if kind == "position":
            self._on_position(t, v, rec.source, rec.t_src)
        elif kind == "heading":
            psi = v.get("heading")
            if _finite(psi):
                self._measure("heading", t, np.array([float(psi)]), rec.source)
        elif kind == "yaw_rate":
            r = v.get("r")
            if _finite(r):
                self._measure("yaw_rate", t, np.array([float(r)]), rec.source)
        elif kind == "accel_body":
            ax, ay = v.get("ax"), v.get("ay")
            if _finite(ax, ay):
                self._measure("accel", t, np.array([float(ax), float(ay)]), rec.source)
        elif kind == "velocity_ground":
            sog, cog = v.get("sog"), v.get("cog")
            vg = self._vg
            if vg is not None and rec.source == self._vg_source and 0.0 <= t - vg[0] < REPEAT_WINDOW and (
                    t == vg[0] or (_finite(sog, cog) and (vg[1], vg[2]) == (float(sog) * math.cos(cog),
                                                                           float(sog) * math.sin(cog)))):
                # one receiver's velocity told twice (RMC and VTG of one fix): one update
                self.rejected["velocity_ground.repeat"] += 1
            elif _finite(sog, cog) and (self._vg_source is None or self._vg_source == rec.source
                                        or vg is None or t - vg[0] > VG_MAX_AGE):
                self._vg_source = rec.source  # one receiver's, the first heard (or the one speaking)
                self._vg = (t, float(sog) * math.cos(cog), float(sog) * math.sin(cog))
                self._sog_check(t, self._vg[1], self._vg[2])
                if self.cfg.use_sog:
                    self._measure("velocity", t, np.array([self._vg[1], self._vg[2]]), rec.source)
                self._start_if_slow(t)  # a slow receiver's SOG/COG, just after its fix
        elif kind == "current":
            set_, drift = v.get("set"), v.get("drift")
            if _finite(set_, drift):
                self._current = (t, float(drift) * math.cos(set_), float(drift) * math.sin(set_))
        return []

    def _gap(self, t: float) -> None:
        """A gap of more than `reset_after` s since the last input (any kind): the
        filter starts again from what follows (`_start_again`), counted `gap`."""
        last = self._t_input
        if last is None or t > last:
            self._t_input = t
        if last is not None and t - last > self.cfg.reset_after:
            if self.filter is not None or self._fixes:
                self.resets["gap"] += 1
                self.monitor.reset(f"a gap of {t - last:.0f} s in every input", t)
                self._start_again()
            self._heading = self._rate = None

    def _on_stw(self, e: Estimate) -> None:
        c, set_ = e.values.get("current"), e.values.get("current_set")
        if _finite(c, set_):
            self._current = (e.t, float(c) * math.cos(set_), float(c) * math.sin(set_))

    def _on_position(self, t: float, v: dict[str, Any], source: str, t_src: float | None = None) -> None:
        lat, lon = v.get("lat"), v.get("lon")
        if not _finite(lat, lon) or v.get("fix_quality") == 0:
            self.rejected["position.no_fix"] += 1
            return
        last = self._last_fix.get(source)
        if last is not None and 0.0 <= t - last[0] < REPEAT_WINDOW and (
                t == last[0] or (last[1] == lat and last[2] == lon) or (t_src is not None and t_src == last[3])):
            # one fix told again: GGA, RMC and GLL of one receiver (one time, the
            # position perhaps rounded otherwise), or PGN 129029 repeating 129025's;
            # a second update would count it twice
            self.rejected["position.repeat"] += 1
            return
        self._last_fix[source] = (t, lat, lon, t_src)
        if self.plane is None:
            self.plane = LocalPlane(float(lat), float(lon))
        pn, pe = self.plane.to_ne(float(lat), float(lon))
        z = np.array([pn, pe])
        if not self._heard("position", t, z, source):
            return
        self._raw_fix = (t, float(lat), float(lon))
        track = self._track
        if not track or track[-1][0] < t:
            track.append((t, pn, pe))
        while track and track[0][0] < t - TRACK_SPAN:
            track.popleft()
        if self.filter is None:
            if self._fixes_source != source:  # a start fits one receiver's fixes, never a mix
                self._fixes.clear()
                self._fixes_source = source
            self._fixes.append((t, pn, pe))
            self._try_start(t)
            return
        self._measure("position", t, z, source)
        self._move_origin()

    # ------------------------------------------------------------------ start
    def _try_start(self, t: float) -> None:
        cfg = self.cfg
        fixes = self._fixes
        window = float(cfg.init_window)
        while len(fixes) > 3 and fixes[0][0] < t - max(window, START_SPAN):
            fixes.popleft()
        hd = self._heading
        if hd is None or t - hd[0] > START_AGE:
            return
        if window <= 0.0:  # the paper: the last two fixes
            if len(fixes) < 2 or fixes[-1][0] - fixes[-2][0] <= 0.0:
                return
            (t0, n0, e0), (t1, n1, e1) = fixes[-2], fixes[-1]
            dt = t1 - t0
            vn, ve = (n1 - n0) / dt, (e1 - e0) / dt
            var_p = float(cfg.position_sigma) ** 2
            var_v = 2.0 * var_p / dt**2
            cov_pv = var_p / dt
            pos = (n1, e1)
        else:
            # the fixes of the last `init_window` s, or the last three when the GNSS is
            # slower than that (1 Hz: three seconds), within START_SPAN
            recent = [f for f in fixes if f[0] >= t - START_SPAN]
            if len(recent) < 3:
                self._start_slow(t, hd[1])  # a receiver slower than 3 fixes in START_SPAN
                return
            since = min(t - window, recent[-3][0])
            pts = [f for f in recent if f[0] >= since]
            span = pts[-1][0] - pts[0][0]
            slow = recent[-1][0] - recent[-3][0] >= window  # three fixes take the window or more
            if span <= 0.0 or (span < 0.5 * window and not slow):
                return
            ts = np.array([p[0] for p in pts]) - t
            tm = ts.mean()
            sxx = float(((ts - tm) ** 2).sum())
            var_p = float(cfg.position_sigma) ** 2
            fit = [np.polyfit(ts, np.array([p[i] for p in pts]), 1) for i in (1, 2)]
            vn, ve = float(fit[0][0]), float(fit[1][0])
            pos = (float(fit[0][1]), float(fit[1][1]))  # the line at t
            # the line's value and slope at t: var a = σ²(1/n + t̄²/Sxx), var b = σ²/Sxx,
            # cov(a, b) = −σ² t̄/Sxx
            var_v = var_p / sxx
            cov_pv = -var_p * tm / sxx
            var_p = var_p * (1.0 / len(pts) + tm * tm / sxx)
            vg = self._vg
            if var_v > (2.0 * START_VG_SIGMA) ** 2 and vg is not None and 0.0 <= t - vg[0] <= START_AGE + 0.5:
                # a slow receiver's line is steep noise (1 Hz, 1.5 m: its slope's σ is
                # 0.75 m/s): the receiver's own velocity (Doppler, a few cm/s) instead
                vn, ve = vg[1], vg[2]
                var_v = START_VG_SIGMA**2
                cov_pv = 0.0
        self._start(t, pos, vn, ve, hd[1], var_p, var_v, cov_pv)

    def _start(self, t: float, pos: tuple[float, float], vn: float, ve: float, psi: float, var_p: float,
               var_v: float, cov_pv: float) -> None:
        """The filter from a position, a velocity over ground and the heading, with P0
        of eqs. (20)–(22): the starting values' errors spread into the state."""
        cfg = self.cfg
        r = self._rate[1] if self._rate is not None and t - self._rate[0] <= START_AGE else 0.0
        var_r = (float(cfg.yaw_rate_sigma_deg) * DEG) ** 2 if self._rate is not None else START_RATE_SIGMA**2
        m = self.model
        x0 = m.from_motion(pos[0], pos[1], vn, ve, psi, r)
        # P0: eqs. (20)-(22), the errors of the starting values spread into the state
        C = np.zeros((6, 6))
        C[0, 0] = C[1, 1] = var_p
        C[2, 2] = C[3, 3] = var_v
        C[0, 2] = C[2, 0] = C[1, 3] = C[3, 1] = cov_pv
        C[4, 4] = (float(cfg.heading_sigma_deg) * DEG) ** 2
        C[5, 5] = var_r
        J = m.from_motion_jacobian(vn, ve, psi)
        P0 = J @ C @ J.T
        P0[6, 6] = P0[7, 7] = (float(cfg.accel_sigma) if cfg.mode == "paper" else START_ACCEL_SIGMA) ** 2
        for i in range(8, 10 if m.bias else 8):
            P0[i, i] = START_BIAS_SIGMA**2
        if m.yaw.index is not None:  # seen only through a rate gyro (`_Q`)
            P0[m.yaw.index, m.yaw.index] = START_YAW_ACCEL_SIGMA**2 if self._rate is not None else 0.0
        if self._init_rng is not None:  # a Monte-Carlo run's initial error, eq. (13)
            x0 = self._init_rng.multivariate_normal(x0, 0.5 * (P0 + P0.T), method="cholesky")
            x0[PSI] = wrap_2pi(x0[PSI])
        self.filter = self._make_filter(x0, P0)
        self.t = t
        self._t_started = t
        self._since_start.clear()
        self._fixes.clear()

    def _slow(self, t: float) -> bool:
        """The receiver is slow: its last two fixes START_SPAN / 2 or more apart, or its
        only one that old (a 10 Hz receiver's first fixes are not a slow receiver's)."""
        fixes = self._fixes
        if len(fixes) >= 2:
            return fixes[-1][0] - fixes[-2][0] >= 0.5 * START_SPAN
        return bool(fixes) and t - fixes[-1][0] >= 0.5 * START_SPAN

    def _start_if_slow(self, t: float) -> None:
        """A start is tried at every fix; with a slow receiver also when its SOG/COG or
        a heading comes after its fix, so that it need not wait for the next fix."""
        fixes = self._fixes
        if self.filter is None and fixes and t - fixes[-1][0] <= SLOW_START_SPAN and self._slow(t):
            self._try_start(t)

    def _start_slow(self, t: float, psi: float) -> None:
        """A GNSS with a fix every 10–60 s (a ship's receiver thinned to the STW paper's
        30 s) never gives three fixes in START_SPAN: start from the last fix with the
        receiver's own SOG/COG, else from the last two fixes (over 30 s their
        difference is a velocity within 0.07 m/s), the fix carried to now."""
        fixes, cfg = self._fixes, self.cfg
        if not fixes or not self._slow(t) or t - fixes[-1][0] > SLOW_START_SPAN:
            return
        t1, n1, e1 = fixes[-1]
        var_p = float(cfg.position_sigma) ** 2
        vg = self._vg
        if vg is not None and abs(vg[0] - t1) <= START_AGE + 0.5:  # the receiver's velocity at its fix
            vn, ve, var_v, cov_pv = vg[1], vg[2], START_VG_SIGMA**2, 0.0
        elif len(fixes) >= 2 and 0.5 * START_SPAN <= t1 - fixes[-2][0] <= SLOW_START_SPAN:
            t0, n0, e0 = fixes[-2]
            dt = t1 - t0
            vn, ve = (n1 - n0) / dt, (e1 - e0) / dt
            var_v, cov_pv = 2.0 * var_p / dt**2, var_p / dt
        else:
            return
        ahead = t - t1  # the fix carried to now (a heading or SOG/COG after it)
        pos = (n1 + vn * ahead, e1 + ve * ahead)
        var_p, cov_pv = var_p + 2.0 * ahead * cov_pv + ahead * ahead * var_v, cov_pv + ahead * var_v
        self._start(t, pos, vn, ve, psi, var_p, var_v, cov_pv)

    def _make_filter(self, x0: np.ndarray, P0: np.ndarray) -> Any:
        cfg = self.cfg
        if cfg.filter == "ekf":
            from .ekf import Ekf

            return Ekf(self.model, x0, P0, float(cfg.substep))
        if cfg.filter == "ukf":
            from .ukf import Ukf

            return Ukf(self.model, x0, P0, float(cfg.substep))
        from .enkf import Enkf

        return Enkf(self.model, x0, P0, float(cfg.substep), members=cfg.members, seed=cfg.seed,
                    inflation=cfg.inflation)

    # ------------------------------------------------------------------ one update
    def _Q(self) -> np.ndarray:
        gyro = self.t is not None and self.t - self._last_update.get("yaw_rate", -math.inf) <= DRIVER_SPAN
        if self._gyro_states is None or gyro:
            if all(q.scale == 1.0 for q in self.qscales.values()):
                return self.Qc
            # With a rate gyro the yaw group scales the yaw acceleration's noise (r's
            # own stays the configured floor).
            groups = self._gyro_states or self.group_states
            Q = self.Qc.copy()
        else:
            # Without one, there is no yaw acceleration (its noise is 0) and the group
            # scales r's: ṙ would be a second difference of compass readings, 1 Hz of
            # them aliasing a seaway's wave yaw (a yacht's heading went from 2.3 to
            # 3.7 × her compass's error, Aava's gated headings from 22 to 31).
            groups = self.group_states
            Q = self.Qc.copy()
            i = self.model.yaw.index
            Q[i, i] = 0.0
        for g, states in groups.items():
            for i in states:
                Q[i, i] *= self.qscales[g].scale
        if groups is self._gyro_states:
            # r's own noise follows the yaw group down, never up: a calm ship's gyro
            # reading 0.005 °/s is then followed as closely as the paper's filter does
            # (Williamson: yaw-rate NIS 0.25 per dof with it fixed, 1.02 so), and a
            # seaway's yaw is the yaw acceleration's to carry
            Q[R, R] *= min(self.qscales["yaw"].scale, 1.0)
        return Q

    @property
    def converging(self) -> bool:
        """Since the (re)start, fewer than `converge_updates` fixes or headings taken in."""
        n = self.cfg.converge_updates
        return self._since_start["position"] < n or self._since_start["heading"] < n

    @property
    def q_raised(self) -> bool:
        return any(q.raised for q in self.qscales.values())

    def _sigma(self, kind: str, source: str) -> np.ndarray:
        noise = self.noise.get((kind, source))
        return np.sqrt(noise.var) if noise is not None else self.sigma0[kind]

    def _heard(self, kind: str, t: float, z: np.ndarray, source: str) -> bool:
        """A reading judged against the other sources of its kind (`sources.py`): False
        when it is muted (a copy, the source not kept of two that disagree, a GNSS
        receiver standing by). Only what is heard starts the filter."""
        k = KINDS[kind]
        fault = self.faults.judge(kind, source, t, z, float(self._sigma(kind, source)[0]))
        if fault is not None:
            self.rejected[f"{kind}.{fault}"] += 1
            if self.faults.new_doubt and self.filter is not None:
                self.filter.P[PSI, PSI] += self.faults.new_doubt
            return False
        muted = self.copies.muted(kind, source, t, z, lambda a, b: residual(k, a, b), lambda s: self._sigma(kind, s))
        self._disagreed()
        if muted:
            self.muted[kind] += 1
            return False
        if kind == "heading":  # what a start takes (`_try_start`)
            self._heading = (t, float(z[0]))
            self._start_if_slow(t)
        elif kind == "yaw_rate":
            self._rate = (t, float(z[0]))
        return True

    def _measure(self, kind: str, t: float, z: np.ndarray, source: str) -> None:
        if kind != "position" and not self._heard(kind, t, z, source):
            return
        f = self.filter
        if f is None or self.t is None:
            return
        top = None
        if kind in ROUGH_KINDS:  # the raw readings' roughness, before they are averaged
            rough = self.roughness.get((kind, source))
            if rough is None:
                rough = self.roughness[(kind, source)] = Roughness()
            top = rough.add(t, z, lambda a, b: residual(KINDS[kind], a, b))
        block = self.decimator.push(kind, source, t, z, KINDS[kind].angle_rows)
        if block is None:
            return
        t, z, samples, scatter = block
        dt = t - self.t
        if dt < -0.5:
            self.rejected[f"{kind}.late"] += 1
            return
        if dt > self.cfg.reset_after:  # the filter's sensors were silent (only a current spoke)
            self.resets["gap"] += 1
            self.monitor.reset(f"no {'/'.join(KINDS)} for {dt:.0f} s", t)
            self._start_again()
            return
        cfg = self.cfg
        key = (kind, source)
        noise = self.noise.get(key)
        if noise is None:
            # An average of n readings has 1/n of one's variance only if they are
            # independent (a gateway's bursts of repeated readings are not): start from
            # one reading's and let the residuals bring it down.
            noise = self.noise[key] = NoiseEstimate(self.sigma0[kind] ** 2, SIGMA_FLOOR[kind])
        if cfg.adapt_r and cfg.filter != "enkf":
            # Not an ensemble's: perturbed observations far more precise than its spread
            # collapse it through the sampling error of a hundred members (the sway,
            # which no sensor sees, then drifts); its sensors start conservative.
            noise.prime(scatter)
            if top is not None:
                noise.ceiling(top / max(samples, 1))  # a mean of n independent readings
        gate = self.gates.get(key)
        if gate is None:
            gate = self.gates[key] = Gate()
        if dt > 0.0:
            f.predict(dt, self._Q())
            self.t = t
        dof = KINDS[kind].dim
        R_ = noise.R()
        if dt < 0.0:
            z, R_ = self._aligned(kind, z, R_, -dt)
        if kind == "position" and self._far(t, z, source):
            return
        if kind == "position" and cfg.ellipse_window > 0.0 and self.plane is not None:
            # the predictions due by now against this fix, an independent witness (the
            # filter's own later estimate shares its errors: measured, it shrank the
            # 10-s ellipse to hold 30 % of the truths)
            v_ne = self.model.ground_velocity(f.x)
            for c in self.calibration:
                c.due(t, self.plane.to_ne, (float(z[0]), float(z[1])), v_ne, WITNESS_NOISE * R_)
            for b in self.blends:
                b.due(t, self.plane.to_ne, (float(z[0]), float(z[1])), v_ne)
        limit = gate.limit(dof) if cfg.gate else None
        if kind == "accel" and samples <= 1 and self._between_fixes(t):
            R_ = self._slow_accel_R(R_)
        inn = f.update(kind, z, R_, limit)
        self._nis, self._rcond = inn.nis, inn.rcond
        if self.trace is not None:
            self.trace.append((t, kind, inn.nis, dof, inn.applied, _whiten(inn.y, inn.S)))
        if inn.rcond < RCOND_MIN:
            self._diverged(f"rcond(S) {inn.rcond:.2e} at a {kind} update")
            return
        why = _insane(f.x, f.P)
        if why:
            self._diverged(f"{why} after a {kind} update")
            return
        if not inn.applied:
            self.monitor.gated(kind)
            self.rejected[f"{kind}.gate"] += 1
            if cfg.adapt_q and limit is not None:
                # a gated measurement still says the model is off: counted, at most at
                # twice the gate, so that one outlier cannot move Q much
                for q in self._driven_by(kind, t):
                    q.add(t, min(inn.nis, 2.0 * limit), dof)
            gate.result(False)
            if kind in ("position", "velocity") and self._gnss_gated_both(kind, t, source):
                return
            if kind == "position" and gate.in_row >= gate.run:
                self._position_jump(z, R_)
            return
        if gate.result(True):
            self.resets[f"{kind}.gate_released"] += 1
            if cfg.adapt_q:
                for q in self._driven_by(kind, t):
                    q.bump(10.0)
        self.monitor.update(kind, inn.nis, dof)
        self._since_start[kind] += 1
        self._low_rate(t, float(f.x[R]))
        driven = self._driven_by(kind, t)
        if cfg.adapt_q:
            for q in driven:
                q.add(t, inn.nis, dof)
        if cfg.adapt_r and not any(q.raised for q in self._groups_of(kind)):
            noise.add(inn.y, inn.S, R_)  # a manoeuvre is not sensor noise

    def _aligned(self, kind: str, z: np.ndarray, R_: np.ndarray, lag: float) -> tuple[np.ndarray, np.ndarray]:
        """A measurement `lag` s older than the state, carried to the state's time:
        z + (∂h/∂x · f(x))·lag, its covariance raised by lag²·B P Bᵀ (B = ∂h/∂x · ∂f/∂x,
        what the rate's own error adds). An IMU block is stamped at its mean time, up to
        0.05 s behind the 10 Hz gyro that moved the filter on: a yacht's wave yaw
        changes r by 0.5 °/s in that time, 60 × a MEMS gyro's averaged noise, and such
        updates were 13 % of its NIS, gated or pulling r back."""
        m = self.model
        x = self.filter.x
        Hm = m.H(kind, x)
        rate = Hm @ m.f(x)
        B = Hm @ m.F(x)
        return z + rate * lag, R_ + lag * lag * (B @ self.filter.P @ B.T)

    def _low_rate(self, t: float, r: float) -> None:
        """r low-passed: r_lf += (1 − e^(−Δt/τ))·(r − r_lf), at each applied update; and
        the variance of r about it over R_WAVE_TAU s (the wave's yaw)."""
        if self._r_lf is None or self._r_lf_t is None:
            self._r_lf, self._r_lf_t = r, t
            return
        dt = t - self._r_lf_t
        if dt > 0.0:
            self._r_lf += (1.0 - math.exp(-dt / R_LF_TAU)) * (r - self._r_lf)
            self._r_wave_var += (1.0 - math.exp(-dt / R_WAVE_TAU)) * ((r - self._r_lf) ** 2 - self._r_wave_var)
            self._r_lf_t = t

    def _between_fixes(self, t: float) -> bool:
        """No fix for SPARSE_FIX s: the accelerometers are what carries the motion.
        Where the GNSS speaks each second it holds u and v itself, and the wave yaw's
        R (`_slow_accel_R`) would only throw away the surge the IMU sees between fixes
        (yacht:coastal, GNSS at 1 Hz, IMU at 1 Hz: SOG 0.72 → 1.67 × the GNSS's)."""
        newest = max((f[0] for f in self._last_fix.values()), default=None)
        return newest is None or t - newest > SPARSE_FIX

    def _slow_accel_R(self, R_: np.ndarray) -> np.ndarray:
        """An accelerometer read one sample at a time (slower than `max_rate`): its R
        plus what the model cannot follow between samples. A hull yawing about a steady
        course (a yacht's wave yaw, r swinging by σ_r within seconds) has a sway
        acceleration that cancels u·r and a surge one that cancels −v·r; the model's
        accelerations are random walks, and a 1 Hz sample cannot tell them, so the
        Coriolis rows (eqs. 11–12) are off by about u·σ_r and v·σ_r. Taken as they were,
        a yacht's 1 Hz IMU took u from 2.6 to 1.2 m/s within ten seconds of each 30-s
        fix (u RMSE 1.96 m/s; without the IMU 0.32)."""
        u, v = (float(b) for b in self.model.body(self.filter.x)[0:2])
        add = np.array([v * v, u * u]) * self._r_wave_var
        return R_ + np.diag(add)

    def _far(self, t: float, z: np.ndarray, source: str) -> bool:
        """A fix farther from the estimate than the vessel could have gone (JUMP_FAR m
        and JUMP_SIGMAS σ) is kept out for JUMP_HOLD s: a receiver's glitch of 10 km
        for a minute must not move a ship the GNSS's own SOG and the other sensors say
        held her course. The filter coasts meanwhile, its position σ growing, and
        health names the fixes. Still there after JUMP_HOLD, they are the position."""
        f = self.filter
        d = float(np.hypot(z[0] - f.x[0], z[1] - f.x[1]))
        sigma = math.sqrt(max(float(f.P[0, 0] + f.P[1, 1]), 0.0))
        if d <= max(JUMP_FAR, JUMP_SIGMAS * sigma):
            self._far_since.pop(source, None)
            return False
        since = self._far_since.setdefault(source, t)
        if t - since < JUMP_HOLD:
            self.rejected["position.far"] += 1
            self._far_what = f"position/{source}: fixes {d / 1000.0:.1f} km from the track for {t - since:.0f} s, kept out"
            return True
        del self._far_since[source]
        self.filter.reset_position(z, self.noise[("position", source)].R())
        self.resets["position_jump"] += 1
        return True

    def _gnss_gated_both(self, kind: str, t: float, source: str) -> bool:
        """A position and a velocity of one GNSS epoch both kept out by their gates: the
        vessel did what the filter did not expect (a yacht in a seaway between 30-s
        fixes lost her speed to 0 and stayed there, 28 SOG/COG gated in 30 minutes; a
        tanker's order to slow down). The filter starts again from this epoch's fix and
        SOG/COG (counted `diverged`). A fix that jumped alone leaves the velocity in its
        gate, and is held out as before."""
        other = self._gnss_gated.get("velocity" if kind == "position" else "position")
        self._gnss_gated[kind] = t
        if other is None or abs(t - other) > GNSS_EPOCH:
            return False
        fix = self._raw_fix
        self._gnss_gated.clear()
        self._diverged("a GNSS position and velocity of one epoch both beyond their gates: "
                       "a manoeuvre the filter missed")
        if fix is not None and self.plane is not None and abs(fix[0] - t) <= GNSS_EPOCH:
            pn, pe = self.plane.to_ne(fix[1], fix[2])
            if kind == "position":
                self._fixes_source = source
            self._fixes.append((fix[0], pn, pe))
        return True

    def _sog_check(self, t: float, vn: float, ve: float) -> None:
        """The GNSS's own SOG/COG against the estimate's velocity over ground: SOG_OFF_RUN
        in a row beyond SOG_OFF_SIGMAS σ and SOG_OFF m/s is a filter that has lost
        itself (saturated accelerometers once took it to 457 m/s): it starts again."""
        f = self.filter
        if f is None or self.t is None or abs(t - self.t) > 1.0:
            return
        en, ee = self.model.ground_velocity(f.x)
        J = self.model.body_jacobian(f.x)
        body_var = np.diag(J @ f.P @ J.T)
        sigma = math.sqrt(max(float(body_var[0] + body_var[1]), 0.0) + SOG_SIGMA**2)
        off = math.hypot(en - vn, ee - ve)
        if off > max(SOG_OFF, SOG_OFF_SIGMAS * sigma):
            self._sog_off += 1
            if self._sog_off >= SOG_OFF_RUN:
                self._sog_off = 0
                self._diverged(f"velocity {off:.1f} m/s from the GNSS's SOG/COG")
        else:
            self._sog_off = 0

    def _groups_of(self, kind: str) -> list[QScale]:
        return [self.qscales[g] for g, (kinds, _) in GROUPS.items() if kind in kinds]

    def _driven_by(self, kind: str, t: float) -> list[QScale]:
        """The groups whose preferred sensor, of those heard in the last DRIVER_SPAN s,
        is `kind` (`GROUPS`)."""
        self._last_update[kind] = t
        out = []
        for g, (kinds, _) in GROUPS.items():
            for k in kinds:
                if t - self._last_update.get(k, -math.inf) <= DRIVER_SPAN:
                    if k == kind:
                        out.append(self.qscales[g])
                    break
        return out

    def _position_jump(self, z: np.ndarray, R_: np.ndarray) -> None:
        """Fixes kept out `run` times in a row: the GNSS position jumped (or the vessel
        was moved). The position starts again from the new fix; velocities, heading and
        the rest are kept. Within `RESTART_SPAN` s of the start, the start itself was
        wrong (a velocity from a few noisy fixes that the accelerometers cannot
        correct, and that keeps the fixes out): the filter starts again from the fixes."""
        if self.t is not None and self.t - self._t_started < RESTART_SPAN:
            self.resets["start_again"] += 1
            self._start_again()
            return
        self.filter.reset_position(z, R_)
        self.resets["position_jump"] += 1
        for k, g in self.gates.items():
            if k[0] == "position":
                g.in_row = 0

    def _diverged(self, why: str) -> None:
        self.divergences += 1
        self.resets["diverged"] += 1
        self.monitor.reset(why, self.t)
        self._start_again()

    def _start_again(self) -> None:
        """No filter until the next fixes start one (`_try_start`)."""
        self.filter = None
        self.t = None
        for q in self.qscales.values():
            q.reset()
        self._fixes.clear()
        for c in self.calibration:
            c.forget_pending()
        for b in self.blends:
            b.forget_pending()
        self._r_lf = self._r_lf_t = None
        self._r_wave_var = 0.0
        self._sideways = None
        self.faults.forget()
        self._far_since.clear()
        self._sog_off = 0
        self._gnss_gated.clear()

    def _choose(self, kind: str, first: str, second: str, z1: np.ndarray, z2: np.ndarray) -> tuple[str, str]:
        """Which of two disagreeing sources to keep: for compasses, the one nearer the
        course over ground when the vessel makes way; else the one heard first (the
        one the filter has followed longest)."""
        if kind == "heading":
            cog = self._track_course()
            if cog is not None:
                d1 = abs(float(wrap_pi(float(z1[0]) - cog)))
                d2 = abs(float(wrap_pi(float(z2[0]) - cog)))
                if abs(d1 - d2) >= TRACK_MARGIN:
                    return (first, "nearer the course over ground") if d1 < d2 else (second, "nearer the course over ground")
        return first, "heard first"

    def _track_velocity(self) -> tuple[float, float] | None:
        """The fixes' own velocity over the last TRACK_SPAN s (first to last)."""
        tr = self._track
        if len(tr) < 2 or tr[-1][0] - tr[0][0] < 0.5 * TRACK_SPAN:
            return None
        (t0, n0, e0), (t1, n1, e1) = tr[0], tr[-1]
        return (n1 - n0) / (t1 - t0), (e1 - e0) / (t1 - t0)

    def _track_course(self) -> float | None:
        """The course of the fixes of the last TRACK_SPAN s, when they make way."""
        v = self._track_velocity()
        if v is None or math.hypot(*v) < TRACK_SPEED:
            return None
        return math.atan2(v[1], v[0])

    def _disagreed(self) -> None:
        """Two sources were found to disagree: the filter has been fed their mix, so it
        starts again from the one kept."""
        for d in self.copies.take_new():
            self.resets[f"{d.kind}.sources_disagree"] += 1
            if self.filter is not None:
                self.monitor.reset(f"{d.kind}: {d.first} and {d.second} disagree, {d.kept} kept", self.t)
                self._start_again()

    def _judge_motion(self, t: float, u: float, v: float, sog: float) -> None:
        """Keep the time since which the estimate has moved sideways (`SIDEWAYS_*`)."""
        drift = abs(math.atan2(v, u))
        if sog > SIDEWAYS_SPEED and SIDEWAYS_ANGLE < drift < math.pi - SIDEWAYS_ANGLE:
            since = self._sideways[0] if self._sideways is not None else t
            self._sideways = (since, drift, sog)
        else:
            self._sideways = None

    def problems(self) -> list[str]:
        """What is wrong now, each naming its measurement and source (health)."""
        out = self.faults.problems(self._t_input)
        if self._far_since and self._far_what:
            out.append(self._far_what)
        side = self._sideways
        if side is not None and self._t_input is not None and self._t_input - side[0] >= SIDEWAYS_SPAN:
            out.append(f"heading: the hull moves sideways (drift angle {side[1] / DEG:.0f}° at {side[2]:.1f} m/s "
                       f"over ground for {self._t_input - side[0]:.0f} s): the heading or the positions are wrong")
        for d in self.copies.disagreements():
            out.append(f"{d.kind}: sources {d.first} and {d.second} disagree by {say(d.kind, d.diff, size=True)}; "
                       f"{d.kept} kept ({d.why})")
        for kind, m in self.monitor.snapshot().get("innovation", {}).items():
            dof = m.get("dof") or 1
            if m.get("window", 0) < NIS_PROBLEM_UPDATES or m.get("nis_mean") is None:
                continue
            # too large only: a NIS too small (a static receiver repeating one fix) is a
            # σ that claims less than it knows, not an estimate that is wrong
            if m["nis_mean"] > NIS_PROBLEM_MEAN * dof and (m.get("in_band_95") or 0.0) < NIS_PROBLEM_IN_BAND:
                out.append(f"{kind}: innovations out of their band (NIS mean {m['nis_mean']:.3g} for {dof} dof, "
                           f"{m.get('in_band_95', 0.0):.0%} in the 95 % band over {m['window']} updates)")
        return out

    def _move_origin(self) -> None:
        f = self.filter
        if f is None or self.plane is None:
            return
        x = f.x
        if math.hypot(x[0], x[1]) <= self.cfg.origin_radius:
            return
        dn, de = float(x[0]), float(x[1])
        lat, lon = self.plane.to_geodetic(dn, de)
        self.plane = LocalPlane(lat, lon)
        f.shift(dn, de)
        self._track = deque((tt, n - dn, e - de) for tt, n, e in self._track)
        self.resets["origin_moved"] += 1

    # ------------------------------------------------------------------ output
    def tick(self, t: float) -> list[Estimate]:
        f = self.filter
        if f is None or self.t is None or self.plane is None:
            return []
        if t - self.t > self.cfg.reset_after:
            return []  # nothing since the gap's start: the next input starts again
        # The state at its newest measurement, once: not run on to the tick's time. A
        # tick falls up to a sensor's interval after its last reading, and the model
        # holds r over that time: a yacht yawing ±7 °/s in a seaway had r 0.7 °/s off
        # at a 10 Hz tick, 50 × a 0.02 °/s gyro's error, where the state it came from
        # had the gyro's own.
        if self._published_t is not None and self.t <= self._published_t:
            return []
        t = self._published_t = self.t
        m = self.model
        x = f.x
        P = f.P
        std = np.sqrt(np.maximum(np.diag(P), 0.0))
        body = m.body(x)
        Jb = m.body_jacobian(x)
        body_std = np.sqrt(np.maximum(np.diag(Jb @ P @ Jb.T), 0.0))
        vn, ve = m.ground_velocity(x)
        u, v, a_u, a_v = (float(b) for b in body)
        lat, lon = self.plane.to_geodetic(float(x[0]), float(x[1]))
        drift_water = None
        cur = self._current
        if cur is not None and t - cur[0] <= CURRENT_MAX_AGE:
            psi = float(x[PSI])
            cu = cur[1] * math.cos(psi) + cur[2] * math.sin(psi)
            cv = -cur[1] * math.sin(psi) + cur[2] * math.cos(psi)
            if math.hypot(u - cu, v - cv) > 0.1:
                drift_water = math.atan2(v - cv, u - cu)
        self._judge_motion(t, u, v, math.hypot(vn, ve))
        names = m.names
        std_map = {names[i]: float(std[i]) for i in range(m.n)}
        std_map.update({"u": float(body_std[0]), "v": float(body_std[1]),
                        "a_u": float(body_std[2]), "a_v": float(body_std[3])})
        values: dict[str, Any] = {
            "converging": self.converging,
            "lat": lat, "lon": lon, "x": float(x[0]), "y": float(x[1]),
            "u": u, "v": v, "r": float(x[R]), "heading": float(x[PSI]), "a_u": a_u, "a_v": a_v,
            "sog": math.hypot(vn, ve), "cog": float(wrap_2pi(math.atan2(ve, vn))),
            "drift_angle": math.atan2(v, u) if math.hypot(u, v) > 0.1 else 0.0,
            "drift_angle_water": drift_water,
            "nis": self._nis, "rcond": self._rcond, "q_scale": {g: round(q.scale, 3) for g, q in self.qscales.items()},
            "model": m.name, "filter": self.cfg.filter, "mode": self.cfg.mode,
            "std": std_map,
            "predicted": self._predicted(t, x, P),
        }
        values["accel_bias"] = [float(x[8]), float(x[9])] if m.bias else None
        return [Estimate("manoeuvre", "manoeuvre", t, values)]

    def _predicted(self, t: float, x: np.ndarray, P: np.ndarray) -> list[dict[str, float]]:
        """The prediction rows, made afresh at most `predict_rate` times a second of data
        time; in between, the last rows with `dt` counted from this estimate's time. Each
        is also kept to size its ellipse when it comes due (`calibrate.py`)."""
        plane = self.plane
        assert plane is not None
        rate = self.cfg.predict_rate
        made = self._prediction
        if made is None or rate <= 0.0 or t - made[0] >= 1.0 / rate - 1e-6 or t < made[0]:
            runs = self.predictor.run(x, P, self.Qc)
            rows = self.predictor.predicted(runs, plane.to_geodetic, [c.scale for c in self.calibration])
            if self.cfg.mode != "paper":  # the paper's predictor is the model alone
                self._blend(t, x, P, runs, rows)
            if self.cfg.ellipse_window > 0.0:
                for c, (_, _, Ph), row in zip(self.calibration, runs, rows):
                    c.add(t, row["lat"], row["lon"], Ph[0:2, 0:2])
            self._prediction = made = (t, rows)
        age = t - made[0]
        if age == 0.0:
            return made[1]
        return [{**row, "dt": round(row["dt"] - age, 6)} for row in made[1]]

    def _blend(self, t: float, x: np.ndarray, P: np.ndarray, runs: list, rows: list[dict[str, float]]) -> None:
        """Each row's position and heading from its horizon's blend of the candidates
        (`blend.py`); the ellipse stays the model's, sized on the blend's own errors."""
        plane = self.plane
        assert plane is not None
        x_lf = np.array(x, dtype=float)
        if self._r_lf is not None:
            x_lf[R] = self._r_lf
        runs_lf = self.predictor.run(x_lf, P, self.Qc)
        if self._raw_fix is not None and t - self._raw_fix[0] <= self.cfg.reset_after:
            t_fix, lat0, lon0 = self._raw_fix
            n0, e0 = plane.to_ne(lat0, lon0)
        else:
            t_fix, n0, e0 = t, float(x[0]), float(x[1])
        vf = self.model.ground_velocity(x)
        vt = self._track_velocity() or vf
        vg = self._vg
        if vg is not None and t - vg[0] <= VG_MAX_AGE:
            vn, ve = vg[1], vg[2]
        else:
            vn, ve = vt
        psi0 = float(x[PSI])
        for b, row, (_, x_m, _), (_, x_l, _) in zip(self.blends, rows, runs, runs_lf):
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

    def health(self) -> dict[str, Any]:
        out = self.monitor.snapshot()
        seen = {k: self.seen.get(k, 0) for k in ("position", "heading", "yaw_rate", "accel_body", "current")}
        out["seen"] = seen
        out["missing"] = {k: COSTS[k] for k in COSTS if not seen.get(k)}
        out["running"] = self.filter is not None
        out["model"], out["filter"], out["mode"] = self.model.name, self.cfg.filter, self.cfg.mode
        out["divergences"] = self.divergences
        out["rejected"] = dict(sorted(self.rejected.items()))
        out["events"] = dict(sorted(self.resets.items()))
        out["duplicates"] = self.copies.duplicates()
        out["problems"] = self.problems()
        out["muted"] = dict(sorted(self.muted.items()))
        out["q_scale"] = {g: round(q.scale, 3) for g, q in self.qscales.items()}
        out["nis_ratio"] = {g: round(q.ratio, 3) for g, q in self.qscales.items()}
        out["nis_in_band"] = {g: q.in_band for g, q in self.qscales.items()}
        out["rcond"] = self._rcond
        out["ellipse_scale"] = {f"{c.horizon:g}": round(c.scale, 3) for c in self.calibration}
        out["prediction"] = {f"{b.horizon:g}": b.report() for b in self.blends}
        out["sensor_sigma"] = {f"{k}/{s}": [round(x, 6) for x in n.sigma()] for (k, s), n in sorted(self.noise.items())}
        if self.filter is not None and self.filter.ensemble_size():
            out["members"] = self.filter.ensemble_size()
        return out


#: Variances beyond these are a filter that has lost itself, whatever rcond says (a
#: one-row S always has rcond 1): positions (m²), velocities (m²/s²), heading (rad²).
VAR_MAX = {0: 1e10, 1: 1e10, 2: 1e4, 3: 1e4, 4: 1e2}


def _insane(x: np.ndarray, P: np.ndarray) -> str | None:
    if not np.all(np.isfinite(x)):
        return "a state that is not finite"
    d = np.diag(P)
    if not np.all(np.isfinite(d)) or np.any(d < -1e-9):
        return "a covariance that is not finite or not positive"
    for i, top in VAR_MAX.items():
        if d[i] > top:
            return f"variance {d[i]:.3g} of state {i} beyond {top:g}"
    return None


def _whiten(y: np.ndarray, S: np.ndarray) -> np.ndarray:
    """L⁻¹ y with S = L Lᵀ: the innovation in units of its own σ."""
    try:
        return np.linalg.solve(np.linalg.cholesky(S), y)
    except np.linalg.LinAlgError:
        return np.full_like(y, np.nan)




__all__ = ["ManoeuvreCore", "wrap_pi"]
