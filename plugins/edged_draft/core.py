"""The draft estimator's core: six marks filtered at their sensors' rate, the derived
values at each tick (DESIGN §6 `est/draft`).

Synchronous and fed in data-time order (the worker host ticks it at `publish_rate`):
the same log gives the same estimates at any replay speed. Its health's innovation
statistics are per mark (each mark's sensor is its own stream: `fore_port`, …), one
degree of freedom each; a mark restarted after a jump is a reset.
"""

from __future__ import annotations

import math
from typing import Any

from edged.estimator import ESTIMATES, Estimator, handles
from edged.records import Estimate, Measurement

from . import derived
from .cargo import Cargo
from .config import DraftConfig
from .marks import MarkState
from .noise import MarkNoise
from .paper import PaperMark
from .speed import SpeedFit
from .bank import WaveBank
from .waves import WaveMark, step_marks

#: A mark's first reading and its start: ten seconds, then it is in (its first means
#: carry the sea: let in after 2–6 s, marks were then put out again as disagreeing).
#: Until then the derived values come from the starting marks, `converging`
#: (EARLY_AFTER).
START_SETTLE = 10.0
#: From this long after the first reading (s) the derived values are published from
#: the starting marks' means, `converging`, until the marks are in.
EARLY_AFTER = 2.0
#: The rigid-hull fit is used while its χ² per degree of freedom, averaged over about
#: RIGID_TAU ticks, stays at most RIGID_CHI2 (`_rigid_explains`).
RIGID_TAU = 30.0
RIGID_CHI2 = 3.0
#: Seconds a good mark may disagree with the others before it is out.
DISAGREE_HOLD = 2.0


class DraftCore(Estimator):
    @classmethod
    def upstream(cls, cfg: DraftConfig) -> tuple[str, ...]:
        return (cfg.stw_from,) if cfg.stw_from else ()

    def __init__(self, cfg: DraftConfig) -> None:
        super().__init__(cfg)
        self.cfg: DraftConfig = cfg
        self.bank = WaveBank(cfg.wave_period_min, cfg.wave_period_max, cfg.resonators, cfg.damping, cfg.q_jerk,
                             cfg.q_squat if cfg.squat_from_speed else 0.0)
        self.filters: dict[str, WaveMark | PaperMark] = {}
        self.noise: dict[str, MarkNoise] = {}
        self.state = {m: MarkState(m) for m in derived.MARKS}
        self.speed = SpeedFit(cfg.speed_window, cfg.stw_max_age)
        self.cargo = Cargo(cfg)
        self._retuned: float | None = None
        self._depth: tuple[float, float] | None = None  # t, depth below transducer
        self._water: float | None = None  # water depth (m), the sounder's mean over `depth_window`
        self._t_first: float | None = None  # the first reading's time (the estimator's start)
        self._filled: list[str] = []
        self._rigid_chi2 = 1.0  # `_rigid_explains`: the fit's running χ² per dof
        self._pending: dict[str, tuple[float, float]] = {}  # mark -> (t, draft) not yet filtered

    # ------------------------------------------------------------------ inputs
    @handles(ESTIMATES)
    def _on_stw(self, rec: Estimate) -> None:
        self._flush()  # the speed reads the marks as they are now
        v = rec.values.get("stw")
        if isinstance(v, (int, float)) and math.isfinite(v) and 0.0 <= v < 30.0:
            sd = rec.values.get("stw_std")
            self.speed.add(rec.t, float(v), float(sd) if isinstance(sd, (int, float)) and math.isfinite(sd) else None)
        elif v is not None:  # null: the STW estimator has none yet
            self.rejected["stw.bad_value"] += 1

    @handles("depth")
    def _on_depth(self, rec: Measurement) -> None:
        self._flush()  # a sounding reads the marks as they are now
        d = rec.values.get("depth")
        if isinstance(d, (int, float)) and math.isfinite(d) and d >= 0.0:
            prev = self._depth
            self._depth = (rec.t, float(d))
            self._sounded(rec.t, float(d), None if prev is None else rec.t - prev[0])
        else:
            self.rejected["depth.bad_value"] += 1

    @handles("draft")
    def _on_draft(self, rec: Measurement) -> None:
        t, v = rec.t, rec.values
        cfg = self.cfg
        name = v.get("mark")
        st = self.state.get(name) if isinstance(name, str) else None
        if st is None:
            self.rejected["draft.unknown_mark"] += 1
            return
        if name in self._pending:
            self._flush()
        counted = v.get("lost")
        lost = st.heard(t, counted if isinstance(counted, int) and not isinstance(counted, bool) else None)
        if lost:
            st.counts["lost"] += lost  # health: marks.<mark>.lost
        status = v.get("status", 0)
        st.status = int(status) if isinstance(status, (int, float)) else 1
        if st.status != 0:
            st.out("status")
            self.rejected[f"{name}.status"] += 1
            return
        z = v.get("draft")
        if not isinstance(z, (int, float)) or not math.isfinite(z) or not cfg.min_draft <= z <= cfg.max_draft:
            self.rejected[f"{name}.range"] += 1
            st.range_in_row += 1
            if st.range_in_row >= cfg.jump_after:
                st.out("range")  # not a spike: the sensor reads nonsense
            return
        st.range_in_row = 0
        z = float(z)
        if st.frozen(t, z):  # a sensor at sea never reads one value exactly, reading after reading
            self.rejected[f"{name}.frozen"] += 1
            st.out("frozen")
            return
        f = self.filters.get(name)
        if f is not None and t < f.t - 1e-9:
            self.rejected[f"{name}.late"] += 1
            return
        if f is None:
            if self._t_first is None:
                self._t_first = t
            self._start(name, t, z)
            return
        if isinstance(f, PaperMark):
            self._predict(f, t)
            y, S, nis, applied = f.update(z, self.noise[name].var, cfg.gate)
            self._judged(name, t, z, y, S, nis, applied)
            return
        self._pending[name] = (t, z)  # filtered with the other marks' readings (`_flush`)

    def _flush(self) -> None:
        """The readings held since the last flush, one per mark, filtered together
        (`waves.step_marks`, in the bank's row order), then judged mark by mark (each
        verdict is the mark's own: the order among them changes nothing).

        Held until a mark's next reading, a sounding, an STW estimate or a tick: the
        same records in the same order flush at the same places, so the estimates do
        not depend on how the records were batched on their way here."""
        pending = self._pending
        if not pending:
            return
        self._pending = {}
        filters = self.filters
        names = list(pending)
        marks = [filters[n] for n in names]
        rows = [m.row for m in marks]
        if any(a > b for a, b in zip(rows, rows[1:])):  # the bank's order (the frames' own, mostly)
            names = sorted(names, key=lambda n: filters[n].row)
            marks = [filters[n] for n in names]
        ts = [pending[n][0] for n in names]
        zs = [pending[n][1] for n in names]
        t0 = ts[0]
        speed = self._speed(t0)  # (one instant's readings, mostly: one speed for all)
        speeds = [speed if t == t0 else self._speed(t) for t in ts]
        ys, Ss, nis, applied = step_marks(marks, ts, zs, [self.noise[n].var for n in names], speeds, self.cfg.gate)
        judged = self._judged
        for name, t, z, y, S, q, ok in zip(names, ts, zs, ys.tolist(), Ss.tolist(), nis.tolist(), applied.tolist()):
            judged(name, t, z, y, S, q, ok)

    def _judged(self, name: str, t: float, z: float, y: float, S: float, nis: float, applied: bool) -> None:
        """What a filtered reading says of its mark: jumped, gated, or used."""
        cfg, st = self.cfg, self.state[name]
        if st.gated(not applied, cfg.jump_after):
            st.out("jumped")
            self.reset(f"{name}: most of its last {cfg.jump_after} readings beyond the gate: restarted", t)
            self._start(name, t, z)
            return
        if not applied:
            self.gated(name)
            return
        self.updated(name, nis, 1)
        if cfg.adapt_r:
            self.noise[name].add(y, S)
        if st.lost_share > cfg.max_lost:
            st.out("gaps")
        else:
            st.settle(t)

    def _start(self, name: str, t: float, z: float) -> None:
        cfg = self.cfg
        sigma = math.sqrt(self.noise[name].var) if name in self.noise else cfg.sensor_sigma
        if cfg.mode == "paper":
            self.filters[name] = PaperMark(z, t, cfg.omega_e, cfg.epsilon, cfg.q_v, cfg.q_m, sigma)
        else:
            old = self.filters.get(name)
            self.filters[name] = WaveMark(self.bank, z, t, sigma, cfg.wave_sigma,
                                          amplitude_window=cfg.amplitude_window, squat=self._squat_prior(),
                                          row=old.row if isinstance(old, WaveMark) else None)
        self.noise.setdefault(name, MarkNoise(cfg.sensor_sigma))
        self.state[name].settle(t)

    def _squat_prior(self) -> tuple[float, float]:
        """κ before the ship has shown hers: Barrass per (m/s)², with the configured
        C_b (0.7 if none) and blockage; 1-σ as large as itself, at least 0.02."""
        k = derived.barrass_squat(1.0, self.cfg.block_coefficient or 0.7, self.cfg.blockage)
        return k, max(k, 0.02)

    def _speed(self, t: float) -> tuple[float | None, float]:
        """STW squared at t (m²/s², None: none fresh, or the squat not from the speed)
        and its rate."""
        return self.speed.squared(t) if self.cfg.squat_from_speed else (None, 0.0)

    def _predict(self, f: WaveMark | PaperMark, t: float) -> None:
        if isinstance(f, WaveMark):
            f.predict(t, *self._speed(t))
        else:
            f.predict(t)

    def _retune(self, t: float) -> None:
        """Once a second of data time, the bank's frequencies follow the sea. Called at
        the ticks (after the flush), so that when it happens depends on data time only,
        not on how the readings were grouped: ω moves the whole bank's F, and the
        readings around a retune feel it."""
        if self.cfg.mode == "paper":
            return
        if self._retuned is None:
            self._retuned = t
        elif t - self._retuned >= 1.0:
            self.bank.retune(0.05)
            self._retuned = t

    # ------------------------------------------------------------------ output
    def tick(self, t: float) -> list[Estimate]:
        cfg = self.cfg
        self._flush()
        if not self.filters:
            return []
        self._retune(t)
        marks, means = self._marks_at(t)
        self._drop_disagreeing(t, marks, means)
        self._judge_settling(t, marks, means)
        filled, means, converging = self._filled_means(t, means)
        pos = derived.floating_position(filled, cfg.beam)
        mean_std = self._mean_draft_std(means) if pos["mean_draft"] is not None else None
        values: dict[str, Any] = {"marks": marks, **pos, "mean_draft_std": mean_std, "filled": list(self._filled),
                                  "mode": cfg.mode, "converging": converging}
        values.update(self._squat_ukc(t, filled))
        values.update(self.cargo.at(t, pos["mean_draft"], mean_std))
        return [Estimate("draft", "draft", t, values)]

    def _marks_at(self, t: float) -> tuple[dict[str, dict[str, Any]], dict[str, float | None]]:
        """Each mark's published values at t, and the means of the marks in (None: out).
        Its instantaneous draft is its mean plus the rigid hull's wave part while that
        fit explains the marks (`_rigid_explains`)."""
        marks: dict[str, dict[str, Any]] = {}
        means: dict[str, float | None] = {}
        for name in derived.MARKS:
            st = self.state[name]
            st.check_silence(t, self.cfg.silence)
            f = self.filters.get(name)
            if f is None:
                marks[name] = {"draft": None, "mean": None, "rate": None, "amplitude": None, "std": None, "ok": False}
                means[name] = None
                continue
            self._predict(f, t)  # the readings' time may be behind the tick's by a sample
            marks[name] = {"draft": f.draft, "mean": f.mean, "rate": f.rate, "amplitude": f.amplitude,
                           "std": math.sqrt(max(f.draft_var, 0.0)), "ok": st.ok}
            means[name] = f.mean if st.ok else None
        waves = {m: (marks[m]["draft"] - marks[m]["mean"], marks[m]["std"] ** 2) for m in derived.MARKS
                 if means[m] is not None}
        rigid = derived.rigid_waves(waves) if self.cfg.rigid_hull else None
        if rigid is not None and not self._rigid_explains(waves, rigid):
            rigid = None  # each mark's own sea: the marks meet the waves each at a phase of its own
        if rigid is not None:
            for m, (w, var) in rigid.items():
                f = self.filters[m]
                marks[m]["draft"] = f.mean + w
                marks[m]["std"] = math.sqrt(max(var + f.mean_var, 0.0))
        return marks, means

    def _drop_disagreeing(self, t: float, marks: dict[str, dict[str, Any]], means: dict[str, float | None]) -> None:
        """A good mark that has moved from what the others say of it by 1.5 × `agree` for
        two seconds is out (a jump of 5σ the gate lets through a reading in ten of,
        which the filter then follows; a slow drift). Of a pair that disagree only one
        is wrong, and the geometry cannot say which: the one whose readings the gate
        has stopped more often lately is put out."""
        suspects = []
        for name in derived.MARKS:
            st = self.state[name]
            if st.ok and means[name] is not None:
                exp = derived.fill(name, {**means, name: None})
                if st.drifting(t, None if exp is None else means[name] - exp, 1.5 * self.cfg.agree, DISAGREE_HOLD):
                    suspects.append(name)
        if suspects:
            name = max(suspects, key=lambda m: self.state[m].gated_lately)
            self.state[name].out("disagrees")
            means[name] = None
            marks[name]["ok"] = False

    def _judge_settling(self, t: float, marks: dict[str, dict[str, Any]], means: dict[str, float | None]) -> None:
        """Marks settling back: do they agree with the others? At the estimator's start
        (its first `settle` seconds), a mark not yet in is judged at every tick after
        START_SETTLE: the sea still in the first means may put one past `agree` at the
        first look, and it is not a return."""
        cfg = self.cfg
        for name in derived.MARKS:
            st, f = self.state[name], self.filters.get(name)
            if f is None or st.reason != "settling":
                continue
            starting = st.first and self._t_first is not None and t - self._t_first < cfg.settle
            st.judge(t, START_SETTLE if starting else cfg.settle, cfg.agree, f.mean, derived.fill(name, means))
            if st.ok:
                means[name] = f.mean
                marks[name]["ok"] = True

    def _filled_means(self, t: float, means: dict[str, float | None]) -> tuple[dict[str, float | None],
                                                                              dict[str, float | None], bool]:
        """(means with the marks out filled from their partner and the list, the means
        the σ is taken from, converging). In the estimator's first seconds no mark is in
        yet (each settles START_SETTLE s), but the starting marks' means are known with
        their σ: from EARLY_AFTER the derived values come from them (a mark out for a
        fault is left out, and filled as ever), `converging` (a demo's stayed null for
        ten seconds)."""
        filled = dict(means)
        self._filled = []
        for name in derived.MARKS:
            if means[name] is None:
                v = derived.fill(name, means)
                if v is not None:
                    filled[name] = v
                    self._filled.append(name)
        if all(m is None for m in means.values()) and self._t_first is not None \
                and t - self._t_first >= EARLY_AFTER:
            early = {m: self.filters[m].mean if self._starting(m) else None for m in derived.MARKS}
            filled = dict(early)
            for name in derived.MARKS:
                if early[name] is None:
                    filled[name] = derived.fill(name, early)
            if any(v is not None for v in early.values()):
                return filled, early, True
        return filled, means, False

    def _rigid_explains(self, waves: dict[str, tuple[float, float]], rigid: dict[str, tuple[float, float]]) -> bool:
        """Whether one rigid body's heave, pitch and roll explain the marks' own wave
        parts: the fit's χ² (each mark's residual over its own σ) per degree of freedom,
        averaged over RIGID_TAU s of ticks, at most RIGID_CHI2. A sea whose phase changes
        along the hull (waves of the hull's own length, a short-crested sea) is not a
        rigid motion: taken as one, the fit put 14–19 cm of error on marks whose raw
        readings had 10 (issue 31)."""
        dof = len(rigid) - 3
        if dof <= 0:
            return True
        chi2 = sum((waves[m][0] - rigid[m][0]) ** 2 / max(waves[m][1], 1e-12) for m in rigid) / dof
        self._rigid_chi2 += (chi2 - self._rigid_chi2) / RIGID_TAU
        return self._rigid_chi2 <= RIGID_CHI2

    def _starting(self, name: str) -> bool:
        """A mark in its first start: a filter, never in yet, and not out for a fault."""
        st = self.state[name]
        return name in self.filters and st.first and st.reason in ("starting", "settling")

    def _sounded(self, t: float, below: float, dt: float | None) -> None:
        """The water depth from a sounding: the depth below the transducer plus how deep
        the transducer is at that moment, waves included (the marks' instantaneous
        drafts at the stations, on the line through them), less its height above the
        keel; then a running mean over `depth_window` s (the seabed does not heave, the
        sounder's noise does)."""
        cfg = self.cfg
        inst = {m: (f.draft if self.state[m].ok else None) for m, f in self.filters.items()}
        for m in derived.MARKS:
            if inst.get(m) is None:
                inst[m] = derived.fill(m, inst)
        st = derived.stations(inst)
        if st["fore"] is None or st["aft"] is None:
            return
        if cfg.mark_spacing is not None:
            at = derived.draft_at(cfg.transducer_x, st["fore"], st["aft"], cfg.mark_spacing)
        else:
            at = 0.5 * (st["fore"] + st["aft"])
        water = derived.water_depth(below, at, cfg.transducer_height)
        if self._water is None or dt is None or dt > cfg.depth_max_age:
            self._water = water
        else:
            a = min(1.0, dt / cfg.depth_window)
            self._water += a * (water - self._water)

    def _squat_ukc(self, t: float, filled: dict[str, float | None]) -> dict[str, Any]:
        cfg, speed = self.cfg, self.speed
        squat = squat_std = None
        if cfg.block_coefficient is not None and speed.fresh(t):
            stw = speed.latest[1]  # type: ignore[index]
            squat = derived.barrass_squat(stw, cfg.block_coefficient, cfg.blockage)
            if speed.std is not None and stw > 0.0:
                squat_std = 2.0 * squat / stw * speed.std  # S ∝ V²: dS = 2S/V·dV
        ukc = None
        known = [v for v in filled.values() if v is not None]
        if self._depth is not None and t - self._depth[0] <= cfg.depth_max_age and self._water is not None \
                and known:
            ukc = self._water - max(known)  # below the deepest mark's wave-free draft
        return {"squat": squat, "squat_std": squat_std, "ukc": ukc}

    def _mean_draft_std(self, means: dict[str, float | None]) -> float | None:
        """1-σ of the six marks' mean: their filters' variances, a filled mark's taken
        as twice the measured ones' (its partner's and the list's)."""
        got = [self.filters[m].mean_var for m in derived.MARKS if means[m] is not None]
        if not got:
            return None
        avg = sum(got) / len(got)
        total = sum(got) + 2.0 * avg * len(self._filled)
        n = len(got) + len(self._filled)
        return math.sqrt(max(total, 0.0)) / n

    def details(self) -> dict[str, Any]:
        marks = {}
        for name, st in self.state.items():
            n = self.noise.get(name)
            marks[name] = {"ok": st.ok, "why": st.reason, "sigma": None if n is None else round(math.sqrt(n.var), 5),
                           "disagree": st.disagree, **dict(st.counts)}
        out: dict[str, Any] = {"mode": self.cfg.mode, "marks": marks, "filled": list(self._filled),
                               "out": sorted(m for m, st in self.state.items() if not st.ok)}
        if self.cfg.mode != "paper" and self.filters:
            f = next(iter(self.filters.values()))
            if isinstance(f, WaveMark):
                out["wave_period"] = round(f.peak_period(), 2)
                # the sinkage per (m/s)² of STW the marks have shown (Barrass's prior until
                # the speed changes), fore to aft: the ship's own squat law
                out["squat_coefficient"] = {m: round(g.squat_coefficient, 5) for m, g in self.filters.items()
                                            if isinstance(g, WaveMark)}
        out["rigid"] = {"chi2_per_dof": round(self._rigid_chi2, 2), "used": self._rigid_chi2 <= RIGID_CHI2}
        out["depth"] = self._depth is not None
        out["stw"] = self.speed.latest is not None
        return out

    def problems(self) -> list[str]:
        """What makes the worker not `ok` (the host copies it to health): every mark
        out, for a reason other than the start (six marks reading 0 published six
        means of 0.0 flagged `ok: false` while the worker said `ok: true`)."""
        states = self.state
        if not states or any(st.ok for st in states.values()):
            return []
        if all(st.first and st.reason in ("starting", "settling") for st in states.values()):
            return []  # the estimator's start: each mark's first seconds
        why = ", ".join(f"{m}: {st.reason}" for m, st in states.items())
        return [f"every draft mark is out ({why}): no mean draft, trim, list or UKC"]
