"""The manoeuvring-state estimator's core: measurements in, `est/manoeuvre` out.

The sensors: `position` (lat, lon → the local tangent plane), `heading`, `yaw_rate`,
`accel_body` (ax, ay: the accelerometers, Coriolis terms included), `velocity_ground`
(the GNSS's SOG/COG). `current` measurements, or an `stw` estimator's `est/<name>`,
give the drift angle through the water (seed 001). One handler per input kind
(`@handles`, the contract of `edged.estimator.Estimator`); every measurement first
passes the gap check (`step`).

Where the rest is: the start (`start.py`), one measurement through the filter
(`update.py`), the filter itself behind one interface (`filter.py`), the process
noise and its adaptation (`process_noise.py`), sources that copy or contradict each
other (`sources.py`, the compass choice in `track.py`), the GNSS's own checks
(`gnss_checks.py`), the prediction rows (`forecast.py`) and what health calls a
problem (`health.py`). Gated updates, released gates, resets and the process-noise
scale are in health (`health()`, built in one place).
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

import numpy as np

from edged.angles import wrap_2pi
from edged.geo import LocalPlane
from edged.estimator import ESTIMATES, Estimator, handles
from edged.records import Estimate, Measurement
from edged.units import finite_numbers as _finite

from .adaptive import Gate, NoiseEstimate, Roughness
from .cmm import Cmm
from .config import DEG, ManoeuvreConfig
from .ctra import Ctra
from .decimate import Decimator
from .faults import SensorFaults
from .filter import KalmanFilter
from .forecast import VG_MAX_AGE, Anchors, Forecast
from .gnss_checks import GnssChecks
from .health import Sideways, missing, nis_problems
from .model import KINDS, PSI, R, residual, say
from .process_noise import ProcessNoise
from .sources import SourceCopies
from .start import Motion, Start, initial_state, make_filter
from .track import Track
from .update import UpdateSteps
from .wave_yaw import WaveYaw

#: A current older than this (s of data time) no longer gives the drift through the
#: water (a forecast's own validity; the stw estimator publishes every second).
CURRENT_MAX_AGE = 3 * 3600.0
#: The same lat, lon from one source within this many seconds is one fix told again.
REPEAT_WINDOW = 0.9
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
#: A GNSS jump this soon (s) after the start means the start was wrong: start again.
RESTART_SPAN = 20.0


class ManoeuvreCore(UpdateSteps, Estimator):
    """The estimator the worker host drives: `step` per input record, `tick` on the
    publish grid, `health` for its worker's report."""

    #: NIS statistics over the last 200 updates of a kind (10 Hz inputs: 20 s).
    nis_window = 200

    @classmethod
    def upstream(cls, config: ManoeuvreConfig) -> tuple[str, ...]:
        """The stw instance whose current gives the drift through the water."""
        return (config.current_from,) if config.current_from else ()

    def __init__(self, cfg: ManoeuvreConfig, *, init_rng: np.random.Generator | None = None) -> None:
        super().__init__(cfg)
        tau = float(cfg.yaw_accel_tau or 0.0)
        self.model: Ctra | Cmm = Ctra(bool(cfg.imu_bias), tau) if cfg.model == "ctra" else Cmm(bool(cfg.imu_bias), tau)
        self.process = ProcessNoise(cfg, self.model)
        self.sigma0 = {
            "position": np.full(2, float(cfg.position_sigma)),
            "heading": np.array([float(cfg.heading_sigma_deg) * DEG]),
            "yaw_rate": np.array([float(cfg.yaw_rate_sigma_deg) * DEG]),
            "accel": np.full(2, float(cfg.accel_sigma)),
            "velocity": np.full(2, float(cfg.velocity_sigma)),
        }
        self.filter: KalmanFilter | None = None
        self.t: float | None = None  # the filter's time: its newest measurement's
        self._published_t: float | None = None  # the time of the last state `tick` published
        self.plane: LocalPlane | None = None
        self.start = Start(cfg)
        self.track = Track()
        self.wave = WaveYaw()
        self.forecast = Forecast(cfg, self.model)
        self.gnss = GnssChecks()
        self.sideways = Sideways()
        self.decimator = Decimator(float(cfg.max_rate))
        self.faults = SensorFaults()
        self.copies = SourceCopies(DISAGREE_FLOOR, self.track.choose, one_at_a_time=frozenset({"position", "velocity"}))
        self.noise: dict[tuple[str, str], NoiseEstimate] = {}
        self.roughness: dict[tuple[str, str], Roughness] = {}
        self.gates: dict[tuple[str, str], Gate] = {}
        self._init_counts()
        self._raw_fix: tuple[float, float, float] | None = None  # t, lat, lon of the last fix taken
        self._vg: tuple[float, float, float] | None = None  # t, v_n, v_e of the GNSS's own SOG/COG
        self._vg_source: str | None = None
        self._last_fix: dict[str, tuple[float, Any, Any, float | None]] = {}
        self._current: tuple[float, float, float] | None = None  # t, v_n, v_e of the water
        self._init_rng = init_rng
        self._t_started = -math.inf
        self._t_input: float | None = None  # the newest input's data time
        #: When a list (the Monte-Carlo harness sets one): (t, kind, NIS, dof, applied,
        #: whitened innovation S^(-1/2) y) of every update, for the paper's tables.
        self.trace: list[tuple[float, str, float, int, bool, np.ndarray]] | None = None

    def _init_counts(self) -> None:
        """What health counts and reports beyond the shared counts (`Estimator`)."""
        self.muted: Counter[str] = Counter()
        self.resets: Counter[str] = Counter()
        self.divergences = 0
        self._since_start: Counter[str] = Counter()  # updates applied since the start
        self._nis: float | None = None
        self._rcond: float | None = None

    # ------------------------------------------------------------------ inputs
    def step(self, rec: Measurement | Estimate) -> list[Estimate]:
        """Every measurement first tells the gap check its time; then its handler."""
        if not isinstance(rec, Estimate):
            self._gap(rec.t)
        return super().step(rec)

    @handles("heading")
    def _on_heading(self, rec: Measurement) -> None:
        psi = rec.values.get("heading")
        if _finite(psi):
            self._measure("heading", rec.t, np.array([float(psi)]), rec.source)

    @handles("yaw_rate")
    def _on_yaw_rate(self, rec: Measurement) -> None:
        r = rec.values.get("r")
        if _finite(r):
            self._measure("yaw_rate", rec.t, np.array([float(r)]), rec.source)

    @handles("accel_body")
    def _on_accel_body(self, rec: Measurement) -> None:
        ax, ay = rec.values.get("ax"), rec.values.get("ay")
        if _finite(ax, ay):
            self._measure("accel", rec.t, np.array([float(ax), float(ay)]), rec.source)

    @handles("velocity_ground")
    def _on_velocity_ground(self, rec: Measurement) -> None:
        """The GNSS's own SOG/COG: one receiver's (the first heard, or the one speaking
        when it has been silent VG_MAX_AGE s), checked against the estimate, an update
        with `use_sog`, and what a slow receiver's start waits for."""
        t, sog, cog = rec.t, rec.values.get("sog"), rec.values.get("cog")
        vg = self._vg
        if vg is not None and rec.source == self._vg_source and 0.0 <= t - vg[0] < REPEAT_WINDOW and (
                t == vg[0] or (_finite(sog, cog) and (vg[1], vg[2]) == (float(sog) * math.cos(cog),
                                                                       float(sog) * math.sin(cog)))):
            # one receiver's velocity told twice (RMC and VTG of one fix): one update
            self.rejected["velocity_ground.repeat"] += 1
        elif _finite(sog, cog) and (self._vg_source is None or self._vg_source == rec.source
                                    or vg is None or t - vg[0] > VG_MAX_AGE):
            self._vg_source = rec.source
            self._vg = (t, float(sog) * math.cos(cog), float(sog) * math.sin(cog))
            self._sog_check(t, self._vg[1], self._vg[2])
            if self.cfg.use_sog:
                self._measure("velocity", t, np.array([self._vg[1], self._vg[2]]), rec.source)
            self._start_if_slow(t)  # a slow receiver's SOG/COG, just after its fix

    @handles("current")
    def _on_current(self, rec: Measurement) -> None:
        set_, drift = rec.values.get("set"), rec.values.get("drift")
        if _finite(set_, drift):
            self._current = (rec.t, float(drift) * math.cos(set_), float(drift) * math.sin(set_))

    @handles(ESTIMATES)
    def _on_stw(self, e: Estimate) -> None:
        c, set_ = e.values.get("current"), e.values.get("current_set")
        if _finite(c, set_):
            self._current = (e.t, float(c) * math.cos(set_), float(c) * math.sin(set_))

    @handles("position")
    def _on_position(self, rec: Measurement) -> None:
        t, v, source, t_src = rec.t, rec.values, rec.source, rec.t_src
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
        self.track.add(t, pn, pe)
        if self.filter is None:
            self.start.add_fix(t, pn, pe, source)
            self._try_start(t)
            return
        self._measure("position", t, z, source)
        self._move_origin()

    def _gap(self, t: float) -> None:
        """A gap of more than `reset_after` s since the last input (any kind): the
        filter starts again from what follows (`_start_again`), counted `gap`."""
        last = self._t_input
        if last is None or t > last:
            self._t_input = t
        if last is not None and t - last > self.cfg.reset_after:
            if self.filter is not None or self.start.fixes:
                self.resets["gap"] += 1
                self.reset(f"a gap of {t - last:.0f} s in every input", t)
                self._start_again()
            self.start.heading = self.start.rate = None

    # ------------------------------------------------------------------ sources
    def _sigma(self, kind: str, source: str) -> np.ndarray:
        noise = self.noise.get((kind, source))
        return np.sqrt(noise.var) if noise is not None else self.sigma0[kind]

    def _heard(self, kind: str, t: float, z: np.ndarray, source: str) -> bool:
        """A reading judged against the other sources of its kind (`sources.py`): False
        when it is muted (a copy, the source not kept of two that disagree, a GNSS
        receiver standing by). Only what is heard starts the filter."""
        k = KINDS[kind]
        # the source's σ says how far a repeating compass may let the ship turn (only a
        # heading's is read: `SensorFaults.judge`)
        sigma = float(self._sigma(kind, source)[0]) if kind == "heading" else 0.0
        fault = self.faults.judge(kind, source, t, z, sigma)
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
            self.start.heading = (t, float(z[0]))
            self._start_if_slow(t)
        elif kind == "yaw_rate":
            self.start.rate = (t, float(z[0]))
        return True

    def _disagreed(self) -> None:
        """Two sources were found to disagree: the filter has been fed their mix, so it
        starts again from the one kept."""
        for d in self.copies.take_new():
            self.resets[f"{d.kind}.sources_disagree"] += 1
            if self.filter is not None:
                self.reset(f"{d.kind}: {d.first} and {d.second} disagree, {d.kept} kept", self.t)
                self._start_again()

    # ------------------------------------------------------------------ start
    def _try_start(self, t: float) -> None:
        m = self.start.motion(t, self._vg)
        if m is not None:
            self._begin(t, m)

    def _start_if_slow(self, t: float) -> None:
        """A start is tried at every fix; with a slow receiver also when its SOG/COG or
        a heading comes after its fix, so that it need not wait for the next fix."""
        if self.filter is None and self.start.waits_for_slow(t):
            self._try_start(t)

    def _begin(self, t: float, m: Motion) -> None:
        """The filter from a start's motion (`start.py`)."""
        x0, P0 = initial_state(self.cfg, self.model, t, m, self.start.rate, self._init_rng)
        self.filter = make_filter(self.cfg, self.model, x0, P0)
        self.t = t
        self._t_started = t
        self._since_start.clear()
        self.start.fixes.clear()

    # ------------------------------------------------------------------ resets
    def _sog_check(self, t: float, vn: float, ve: float) -> None:
        """A SOG/COG the estimate has left far behind (`GnssChecks.sog_off`): it starts again."""
        f = self.filter
        if f is None or self.t is None or abs(t - self.t) > 1.0:
            return
        off = self.gnss.sog_off(vn, ve, self.model, f.x, f.P)
        if off is not None:
            self._diverged(f"velocity {off:.1f} m/s from the GNSS's SOG/COG")

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
        self.reset(why, self.t)
        self._start_again()

    def _start_again(self) -> None:
        """No filter until the next fixes start one (`_try_start`)."""
        self.filter = None
        self.t = None
        self.process.reset()
        self.start.fixes.clear()
        self.forecast.forget_pending()
        self.wave.forget()
        self.sideways.forget()
        self.faults.forget()
        self.gnss.forget()

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
        self.track.shift(dn, de)
        self.resets["origin_moved"] += 1

    # ------------------------------------------------------------------ output
    @property
    def converging(self) -> bool:
        """Since the (re)start, fewer than `converge_updates` fixes or headings taken in."""
        n = self.cfg.converge_updates
        return self._since_start["position"] < n or self._since_start["heading"] < n

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
        return [Estimate("manoeuvre", "manoeuvre", t, self._values(t, f.x, f.P, self.plane))]

    def _values(self, t: float, x: np.ndarray, P: np.ndarray, plane: LocalPlane) -> dict[str, Any]:
        """The published estimate (DESIGN §6 `est/manoeuvre`) of state x, P at t."""
        m = self.model
        std = np.sqrt(np.maximum(P.diagonal(), 0.0)).tolist()
        body_std = np.sqrt(np.maximum(m.body_var(x, P), 0.0)).tolist()
        vn, ve = m.ground_velocity(x)
        u, v, a_u, a_v = (float(b) for b in m.body(x))
        lat, lon = plane.to_geodetic(float(x[0]), float(x[1]))
        self.sideways.judge(t, u, v, math.hypot(vn, ve))
        std_map = dict(zip(m.names, std))
        std_map.update(zip(("u", "v", "a_u", "a_v"), body_std))
        anchors = Anchors(self.wave.r_lf, self._raw_fix, self.track.velocity(), self._vg)
        return {
            "converging": self.converging,
            "lat": lat, "lon": lon, "x": float(x[0]), "y": float(x[1]),
            "u": u, "v": v, "r": float(x[R]), "heading": float(x[PSI]), "a_u": a_u, "a_v": a_v,
            "sog": math.hypot(vn, ve), "cog": float(wrap_2pi(math.atan2(ve, vn))),
            "drift_angle": math.atan2(v, u) if math.hypot(u, v) > 0.1 else 0.0,
            "drift_angle_water": self._drift_water(t, float(x[PSI]), u, v),
            "nis": self._nis, "rcond": self._rcond, "q_scale": self.process.scales(),
            "model": m.name, "filter": self.cfg.filter, "mode": self.cfg.mode,
            "std": std_map,
            "predicted": self.forecast.rows(t, x, P, self.process.Qc, plane, anchors),
            "accel_bias": [float(x[8]), float(x[9])] if m.bias else None,
        }

    def _drift_water(self, t: float, psi: float, u: float, v: float) -> float | None:
        """The drift angle through the water, from a current at most CURRENT_MAX_AGE old."""
        cur = self._current
        if cur is None or t - cur[0] > CURRENT_MAX_AGE:
            return None
        cu = cur[1] * math.cos(psi) + cur[2] * math.sin(psi)
        cv = -cur[1] * math.sin(psi) + cur[2] * math.cos(psi)
        if math.hypot(u - cu, v - cv) > 0.1:
            return math.atan2(v - cv, u - cu)
        return None

    # ------------------------------------------------------------------ health
    def problems(self) -> list[str]:
        """What is wrong now, each naming its measurement and source (health)."""
        out = self.faults.problems(self._t_input)
        out += [p for p in (self.gnss.problem(), self.sideways.problem(self._t_input)) if p]
        for d in self.copies.disagreements():
            out.append(f"{d.kind}: sources {d.first} and {d.second} disagree by {say(d.kind, d.diff, size=True)}; "
                       f"{d.kept} kept ({d.why})")
        return out + nis_problems(self.monitor.snapshot())

    def details(self) -> dict[str, Any]:
        """Its own health keys, after the shared ones (`Estimator.health`)."""
        out: dict[str, Any] = {"missing": missing(self.seen)}
        out["running"] = self.filter is not None
        out["model"], out["filter"], out["mode"] = self.model.name, self.cfg.filter, self.cfg.mode
        out["divergences"] = self.divergences
        out["events"] = dict(sorted(self.resets.items()))
        out["duplicates"] = self.copies.duplicates()
        out["muted"] = dict(sorted(self.muted.items()))
        qscales = self.process.qscales
        out["q_scale"] = self.process.scales()
        out["nis_ratio"] = {g: round(q.ratio, 3) for g, q in qscales.items()}
        out["nis_in_band"] = {g: q.in_band for g, q in qscales.items()}
        out["rcond"] = self._rcond
        out.update(self.forecast.report())
        out["sensor_sigma"] = {f"{k}/{s}": [round(x, 6) for x in n.sigma()] for (k, s), n in sorted(self.noise.items())}
        if self.filter is not None and self.filter.ensemble_size():
            out["members"] = self.filter.ensemble_size()
        return out


__all__ = ["ManoeuvreCore"]
