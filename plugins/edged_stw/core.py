"""The STW estimator core: measurements in data-time order in, estimates at ticks out.

It owns what both modes share: which inputs arrived and which are missing (and what
that costs), the IMU averaging, the forecasts (their age, repeats, correlation and
gate), the GNSS gates and their recovery, and the health report. The filters
themselves are `vector.VectorModel` and `paper.PaperModel`; the heading and rate of
turn are `motion.Motion`'s, the Doppler log beside the estimate `logcheck.LogCheck`'s.
"""

from __future__ import annotations

import logging
import math
from collections import Counter, deque
from typing import Any

from edged.estimator import Estimator, handles
from edged.geo import haversine
from edged.records import Estimate, Measurement

from .config import StwConfig
from .inputs import COSTS, GROUND, WATCHED, finite as _finite
from .logcheck import LogCheck
from .motion import Motion
from .paper import PaperModel
from .vector import VectorModel
from .watch import NisWatch

log = logging.getLogger("edged.stw")

#: No sea current runs faster (m/s; the Pentland Firth's 8 m/s is among the fastest).
MAX_CURRENT = 10.0
#: Accelerations beyond this (m/s², 2 g) are not a ship's.
MAX_ACCEL = 20.0
#: The log is fitted only against an STW known better than this (m/s).
DVL_FIT_MAX_STD = 0.5
#: A position and a velocity this close in time (s) are one GNSS epoch.
GNSS_EPOCH = 0.5


class StwCore(Estimator):
    def __init__(self, cfg: StwConfig) -> None:
        super().__init__(cfg)
        self.cfg: StwConfig = cfg
        self.model: VectorModel | PaperModel = VectorModel(cfg) if cfg.mode == "vector" else PaperModel(cfg)
        self.motion = Motion(cfg.heading_average, cfg.turn_rate_max_deg, cfg.turn_settle)
        self.log = LogCheck(cfg, self)
        self._accel: list[float] | None = None  # [t_first, t_last, sum_n, sum_e, n]
        self._last_forecast: tuple[str, float, float, float | None] | None = None
        self._forecast_t = -math.inf  # data time of the last accepted forecast
        self._constant_t = -math.inf
        self._gated_in_row: Counter[str] = Counter()
        #: Per GNSS kind, the last measurement the gate kept out (t, how to trust it).
        self._gated_last: dict[str, tuple[float, Any]] = {}
        self._pending_forecast: tuple[float, float, float, float] | None = None
        self._forecast_nis: list[float] = []
        #: The last forecast used (t, set, drift, σ): it starts a restarted filter.
        self._used_forecast: tuple[float, float, float, float] | None = None
        self._ground_t: float | None = None  # data time of the last GNSS measurement
        self._fix: tuple[float, float] | None = None  # the last position taken
        self._log_forecast = False  # the log's current copy has seen a forecast
        self._recent: dict[str, deque[bool]] = {}  # gate verdicts per kind (True: gated)
        self.nis_watch = NisWatch()
        self._carry_distance: float | None = None  # the distance before a gap, for the next filter
        self._published_distance = 0.0

    # ------------------------------------------------------------------ inputs
    def step(self, rec: Measurement | Estimate) -> list[Estimate]:
        """Around each input's handler: a gap in the GNSS restarts the filter, the paper
        model advances and the ground filter takes the rate of turn; after it, a forecast
        held for the filter's start is used and the constant current comes due."""
        if rec.route_key not in self._dispatch:
            return []
        t = rec.t
        if rec.kind in GROUND and self._ground_t is not None and t - self._ground_t > self.cfg.reset_after:
            self._restart(t, f"no GNSS for {t - self._ground_t:.0f} s (reset_after {self.cfg.reset_after:g} s): "
                             "restarted from the next measurements")
        m = self.model
        if isinstance(m, VectorModel):
            g = m.ground
            if g is not None:
                g.r = self.motion.rate(t)
            was_ready = g is not None
        else:
            for nis in m.advance(t):
                self.updated("gnss", nis, 2)
            was_ready = m.ready
        super().step(rec)
        if not was_ready and self._pending_forecast is not None and self.model.ready:
            t_f, *forecast = self._pending_forecast
            self._pending_forecast = None
            if t - t_f <= self.cfg.forecast_max_age:
                self._forecast(t, *forecast)
            else:
                self.rejected["current.stale"] += 1
        if self.cfg.current is not None:
            self._constant_current(t)
        return []

    def _restart(self, t: float, reason: str) -> None:
        """A gap in the data: a new filter, started by the measurements that follow.
        Predicting across the gap would turn the last acceleration and the current's
        rate into hundreds of m/s; the distance goes on from where it was, plus the
        straight line from the last fix before the gap to the first one after it (the
        least the vessel can have made good)."""
        old = self.model
        last = None
        if self._ground_t is not None and old.ready:
            last = old.estimate(self._ground_t) if isinstance(old, PaperModel) else old.estimate(self._ground_t, None)
        distance = float(last["distance"]) if last is not None else 0.0
        self.model = VectorModel(self.cfg) if self.cfg.mode == "vector" else PaperModel(self.cfg)
        self._carry_distance = distance
        self._accel = None
        self._gated_in_row.clear()
        self._gated_last.clear()
        self._forecast_nis.clear()
        self._forecast_t = -math.inf
        self._constant_t = -math.inf
        self._log_forecast = False
        self._ground_t = None
        if self._used_forecast is not None:
            self._pending_forecast = self._used_forecast
        self.reset(reason, t)
        log.info("stw: %s", reason)

    @handles("position")
    def _on_position(self, rec: Measurement) -> None:
        t, v = rec.t, rec.values
        lat, lon = v.get("lat"), v.get("lon")
        if not _finite(lat, lon):
            self.rejected["position.incomplete"] += 1
            return
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            self.rejected["position.implausible"] += 1
            return
        self._ground_t = t
        carry = self._carry_distance
        if carry is not None and isinstance(self.model, VectorModel) and not self.model.ready:
            if self._fix is not None:
                carry += haversine(self._fix[0], self._fix[1], lat, lon)
            # Never below what was published (dead reckoning in the gap's first minutes).
            self.model.distance = max(carry, self._published_distance)
            self._carry_distance = None
        self._fix = (lat, lon)
        m = self.model
        if isinstance(m, PaperModel):
            m.position(t, lat, lon)
            return
        nis, used = m.position(t, lat, lon)
        self._gate_result(t, "position", nis, used, lambda: m.reset_position(lat, lon), "position jump")

    @handles("velocity_ground")
    def _on_velocity_ground(self, rec: Measurement) -> None:
        t, v = rec.t, rec.values
        sog, cog = v.get("sog"), v.get("cog")
        if sog is not None and cog is None and _finite(sog) and sog < 0.05:
            cog = 0.0  # stopped: no course, and none needed
        if not _finite(sog, cog):
            self.rejected["velocity_ground.incomplete"] += 1
            return
        if sog > self.cfg.max_sog:
            self.rejected["velocity_ground.implausible"] += 1
            return
        self._ground_t = t
        carry = self._carry_distance
        if carry is not None and isinstance(self.model, VectorModel) and not self.model.ready:
            self.model.distance = max(carry, self._published_distance)  # closed by a SOG: no line
            self._carry_distance = None
        m = self.model
        if isinstance(m, PaperModel):
            m.velocity(t, sog, cog)
            return
        v_n, v_e = sog * math.cos(cog), sog * math.sin(cog)
        nis, used = m.velocity(t, v_n, v_e)
        self._gate_result(t, "velocity_ground", nis, used, lambda: m.reset_velocity(v_n, v_e), "SOG/COG jump")
        if used:
            heading = self.motion.heading_at(t)
            if heading is not None and not self.motion.turning(t):
                res = m.cross(t, heading)
                if res is not None:
                    nis, used = res
                    self._verdict("heading_course", not used)
                    if used:
                        self.updated("heading_course", nis, 1)
                    else:
                        self.gated("heading_course")

    def _verdict(self, kind: str, gated: bool) -> None:
        q = self._recent.get(kind)
        if q is None:
            q = self._recent[kind] = deque(maxlen=50)
        q.append(gated)

    def _gate_result(self, t: float, kind: str, nis: float | None, used: bool, reset: Any, what: str) -> None:
        """Count a GNSS gate's verdict; trust the GNSS again when it keeps disagreeing.

        A position and a velocity of one epoch (within GNSS_EPOCH s) that both fail the
        gate are one story, not two outliers: the vessel did what the filter did not
        expect (an order to slow down taken between 30-s fixes, which a 1 Hz IMU shows
        only within its noise), and the filter restarts from the GNSS at once. A jump
        of the position alone (multipath, a spoofed fix) leaves the velocity in the gate
        and is still kept out until `gnss_reset_after` in a row."""
        self._verdict(kind, not used)
        if used:
            self._gated_in_row[kind] = 0
            self._gated_last.pop(kind, None)
            if nis is not None:
                self.updated(kind, nis, 2)
            return
        self.gated(kind)
        other = self._gated_last.get("position" if kind == "velocity_ground" else "velocity_ground")
        if other is not None and abs(t - other[0]) <= GNSS_EPOCH:
            other[1]()
            reset()
            self._gated_last.clear()
            self._gated_in_row.clear()
            self.reset("GNSS position and velocity both disagree with the filter: a manoeuvre it missed; "
                               "restarted from the GNSS", None)
            return
        self._gated_last[kind] = (t, reset)
        self._gated_in_row[kind] += 1
        if self._gated_in_row[kind] >= self.cfg.gnss_reset_after:
            reset()
            self._gated_in_row[kind] = 0
            self.reset(f"{what}: {self.cfg.gnss_reset_after} rejected in a row, GNSS trusted again", None)

    @handles("heading")
    def _on_heading(self, rec: Measurement) -> None:
        h = rec.values.get("heading")
        if not _finite(h):
            self.rejected["heading.incomplete"] += 1
            return
        self.motion.heading.add(rec.t, h)

    @handles("yaw_rate")
    def _on_yaw_rate(self, rec: Measurement) -> None:
        r = rec.values.get("r")
        if _finite(r):
            self.motion.rot = (rec.t, r)

    @handles("accel_body")
    def _on_accel_body(self, rec: Measurement) -> None:
        t, v = rec.t, rec.values
        ax, ay = v.get("ax"), v.get("ay")
        if not _finite(ax, ay):
            self.rejected["accel_body.incomplete"] += 1
            return
        if abs(ax) > MAX_ACCEL or abs(ay) > MAX_ACCEL:
            self.rejected["accel_body.implausible"] += 1
            return
        m = self.model
        if isinstance(m, PaperModel):
            m.accel(ax, ay)
            return
        psi = self.motion.heading_at(t)
        if psi is None:
            if m.ground is None or m.ground.speed(m.ground.x) < self.cfg.min_speed:
                self.rejected["accel_body.no_heading"] += 1
                return
            psi = math.atan2(m.ground.x[3], m.ground.x[2])  # COG stands in
        c, s = math.cos(psi), math.sin(psi)
        a_n, a_e = c * ax - s * ay, s * ax + c * ay
        blk = self._accel
        if blk is None:
            self._accel = [t, t, a_n, a_e, 1]
        else:
            blk[1] = t
            blk[2] += a_n
            blk[3] += a_e
            blk[4] += 1
        if t - self._accel[0] >= self.cfg.accel_average:
            self._flush_accel()

    def _flush_accel(self) -> None:
        blk = self._accel
        if blk is None:
            return
        self._accel = None
        m = self.model
        assert isinstance(m, VectorModel)
        n = int(blk[4])
        nis, used = m.accel(blk[1], blk[2] / n, blk[3] / n, n)
        if nis is None:
            return
        self._verdict("accel_body", not used)
        if used:
            self.updated("accel_body", nis, 2)
        else:
            self.gated("accel_body")

    @handles("current")
    def _on_current(self, rec: Measurement) -> None:
        t, v = rec.t, rec.values
        set_, drift = v.get("set"), v.get("drift")
        if not _finite(set_, drift):
            self.rejected["current.incomplete"] += 1
            return
        if not 0.0 <= drift <= MAX_CURRENT:
            self.rejected["current.implausible"] += 1
            return
        t_src = rec.t_src
        if t_src is not None and t - t_src > self.cfg.forecast_max_age:
            self.rejected["current.stale"] += 1
            return
        key = (rec.source, set_, drift, t_src)
        if self._last_forecast == key:
            self.rejected["current.repeated"] += 1
            return
        self._last_forecast = key
        self._forecast(t, set_, drift, self.cfg.forecast_sigma)

    def _forecast(self, t: float, set_: float, drift: float, sigma: float) -> None:
        m = self.model
        if not m.ready:
            # Forecasts come every 20 minutes: the one that arrived before the first
            # GNSS fix is kept for the moment the filter starts.
            self._pending_forecast = (t, set_, drift, sigma)
            return
        if isinstance(m, PaperModel):
            m.forecast(t, set_, drift)
            self._forecast_t = t
            self._log_forecast = True
            self._used_forecast = (t, set_, drift, sigma)
            return
        # Forecasts closer together than their errors decorrelate count for less.
        gap = t - self._forecast_t
        var = sigma * sigma * max(1.0, self.cfg.forecast_interval / gap if gap > 0 else math.inf)
        if not math.isfinite(var):
            var = sigma * sigma * 1e6
        c_n, c_e = drift * math.cos(set_), drift * math.sin(set_)
        nis = m.forecast_nis(t, c_n, c_e, var)
        self._verdict("current", not nis <= self.cfg.forecast_gate)
        if not nis <= self.cfg.forecast_gate:
            self.gated("current")
            self._gated_in_row["current"] += 1
            if self._gated_in_row["current"] < 2:
                return
            # Two forecasts in a row disagree with the filter: the filter is wrong.
            m.forget_current()
            self.reset("forecasts disagree with the current estimate: current forgotten", t)
            self._forecast_nis.clear()
            nis = m.forecast_nis(t, c_n, c_e, var)
        self._gated_in_row["current"] = 0
        self.updated("current", nis, 2)
        m.forecast(t, c_n, c_e, var)
        self._log_forecast = True
        self._used_forecast = (t, set_, drift, sigma)
        window = self.cfg.forecast_adapt_window
        if window and m.current is not None:
            self._forecast_nis.append(nis)
            del self._forecast_nis[:-window]
            m.current.adapt(self._forecast_nis, self.cfg.forecast_adapt_limit)
        self._forecast_t = t

    def _constant_current(self, t: float) -> None:
        cc = self.cfg.current
        if cc is None or not self.model.ready:
            return
        if t - self._forecast_t < self.cfg.forecast_max_age and self._forecast_t > self._constant_t:
            return  # real forecasts are arriving
        if t - self._constant_t < self.cfg.forecast_interval:
            return
        self._constant_t = t
        self._forecast(t, math.radians(cc.set_deg), cc.drift, cc.sigma)
        self._forecast_t = t
        self._constant_t = t

    @handles("water_speed")
    def _on_water_speed(self, rec: Measurement) -> None:
        t, z = rec.t, rec.values.get("stw_long")
        if not _finite(z):
            self.rejected["water_speed.incomplete"] += 1
            return
        self.log.reading = (t, z)
        m = self.model
        heading = self.motion.heading_at(t)
        est = None
        if isinstance(m, VectorModel) and m.ready:
            est = m.estimate(t, heading)
        elif isinstance(m, PaperModel) and m.ready:
            est = m.estimate(t)
        if est is not None and est["stw_std"] > DVL_FIT_MAX_STD:
            est = None
        stw = None if est is None else est["stw"]
        stw_std = None if est is None else est["stw_std"]
        verdict = self.log.fit(t, z, m, heading, self.motion.turning(t), self._log_forecast, est)
        self.log.watch.reading(t, z, stw, stw_std, verdict)

    # ------------------------------------------------------------------ output
    def tick(self, t: float) -> list[Estimate]:
        m = self.model
        if self._ground_t is None or t - self._ground_t > self.cfg.reset_after:
            # Nothing since the gap began: a prediction across it would be made up (the
            # host republishes the last estimate as stale meanwhile).
            return []
        if isinstance(m, PaperModel):
            for nis in m.advance(t):
                self.updated("gnss", nis, 2)
            values = m.estimate(t)
            if values is None:
                return []
            ground_std = m.ground_std(t)
        else:
            self._flush_accel()
            res = m.publishable(t, self.motion.heading_at(t))
            if res is None:
                return []
            values, ground_std = res
        if not ground_std <= self.cfg.publish_max_std:
            return []  # the ground velocity is not known yet (a start from positions alone)
        values["converging"] = ground_std > self.cfg.converged_std
        self.log.publish(t, values, self._log_forecast)
        values["mode"] = self.cfg.mode
        self.log.warn(values)
        self._published_distance = max(self._published_distance, float(values["distance"]))
        snap = self.monitor.snapshot()["innovation"]
        recent = {k: sum(q) / len(q) for k, q in self._recent.items() if len(q) >= 10}
        self.nis_watch.check(t, {k: v for k, v in snap.items() if k in WATCHED},
                             {k: v for k, v in recent.items() if k in WATCHED})
        return [Estimate("stw", "stw", t, values)]

    def details(self) -> dict[str, Any]:
        seen = self.seen
        missing = {k: COSTS[k] for k in COSTS if not seen.get(k)}
        if self.cfg.current is not None and "current" in missing:
            missing["current"] = "no current forecast: the configured constant current stands in"
        out: dict[str, Any] = {"mode": self.cfg.mode, "missing": missing, **self.log.details()}
        if isinstance(self.model, VectorModel):
            out.update(self.model.health())
            sigma = self.model.current_sigma()
            out["current_sigma"] = None if sigma is None else round(sigma, 4)
            if self.model.current is not None:
                out["current_q_scale"] = round(self.model.current.q_scale, 3)
        return out

    def problems(self) -> list[str]:
        problems = list(self.nis_watch.problems.values())
        if self.log.watch.problem is not None:
            problems.append(self.log.watch.problem)
        return problems
