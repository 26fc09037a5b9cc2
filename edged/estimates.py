"""The estimate kinds: the one definition of every estimate's fields (DESIGN §6).

Beside the measurement kinds of `edged.records`, this module says what each estimate
kind publishes: every field's name, SI unit, JSON type, whether it may be null, and,
for `edged score`, the truth column it is judged against, the field that carries its
1-σ and the measurement it replaces (so that "better than the sensor" is one table).
The MCAP channel schemas, the Zenoh/MCAP payload (`estimate_to_json`) and the docs
(`kinds_markdown`) are all made from here.

An estimate is published under its estimator instance's name (`[estimators.stw_paper]`
-> `est/stw_paper`); its *kind* (`stw`) says which fields it has. Every kind has the
common fields `t`, `kind`, `stale`, `age` and `converging`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterator

from .records import Estimate

__all__ = [
    "EstField",
    "EstimateKind",
    "ScoredField",
    "ESTIMATE_KINDS",
    "COMMON_FIELDS",
    "DRAFT_MARKS",
    "estimate_to_json",
    "kinds_markdown",
]

#: The six draft marks (DESIGN §5, CAN ids 0x310..0x315 in this order).
DRAFT_MARKS: tuple[str, ...] = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")

#: JSON types a field may have (`unit` says the physical unit of a number).
NUMBER, STRING, BOOL, OBJECT, ARRAY = "number", "string", "boolean", "object", "array"


@dataclass(frozen=True, slots=True)
class EstField:
    """One field of an estimate kind.

    `angle`: an angle in rad, whose errors `edged score` wraps to (−π, π].
    `std`: dotted path, in the same payload, of this field's 1-σ (e.g. `stw_std`,
    `std.u`). `truth`: the truth column it is scored against (`edged score`; the
    simulator's `truth.csv` names); None when no truth exists. `baseline`: the
    measurement (kind, field) this estimate replaces, scored beside it. `derived`:
    names of baselines `edged score` computes from other measurements and scores
    beside this field (`naive_stw`: SOG − the latest current forecast along the
    course, what a crew without this estimator would do); the computations are
    `edged_mcap.scoring.DERIVED`.
    """

    name: str
    unit: str
    doc: str
    type: str = NUMBER
    nullable: bool = False
    angle: bool = False
    std: str | None = None
    truth: str | None = None
    baseline: tuple[str, str] | None = None
    derived: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class ScoredField:
    """A value `edged score` compares with truth: where it is in the payload, where
    its σ is, and which truth column and raw measurement go with it."""

    path: str
    truth: str
    unit: str
    angle: bool = False
    std: str | None = None
    baseline: tuple[str, str] | None = None
    #: For a baseline of a kind with several instances (draft marks): only the
    #: measurements whose `mark` equals this.
    baseline_mark: str | None = None
    #: Derived baselines scored beside it (`EstField.derived`).
    derived: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class EstimateKind:
    name: str
    doc: str
    fields: tuple[EstField, ...]
    #: Per-mark fields (the draft kind's `marks` object), keyed by DRAFT_MARKS.
    mark_fields: tuple[EstField, ...] = ()

    @property
    def field_names(self) -> tuple[str, ...]:
        return tuple(f.name for f in COMMON_FIELDS + self.fields)

    def scored_fields(self) -> Iterator[ScoredField]:
        """Every value of this kind that has a truth column, with its σ and baseline."""
        for f in self.fields:
            if f.truth is not None:
                yield ScoredField(f.name, f.truth, f.unit, f.angle, f.std, f.baseline, derived=f.derived)
        for mark in DRAFT_MARKS if self.mark_fields else ():
            for f in self.mark_fields:
                if f.truth is None:
                    continue
                std = f"marks.{mark}.{f.std}" if f.std else None
                yield ScoredField(
                    f"marks.{mark}.{f.name}",
                    f.truth.format(mark=mark),
                    f.unit,
                    f.angle,
                    std,
                    f.baseline,
                    mark if f.baseline else None,
                    f.derived,
                )


def _f(name: str, unit: str, doc: str, **kw: Any) -> EstField:
    return EstField(name, unit, doc, **kw)


def _n(name: str, unit: str, doc: str, **kw: Any) -> EstField:
    """A number that may be null (not known, not configured)."""
    return EstField(name, unit, doc, nullable=True, **kw)


#: Fields every estimate has. `t` is the record's time and always wins over a value
#: of the same name; `stale`/`age` are set by the worker host, not by the core;
#: `converging` by the core.
COMMON_FIELDS: tuple[EstField, ...] = (
    _f("t", "s", "time the estimate is valid for, UTC seconds (UNIX epoch)"),
    _f("kind", "name", "estimate kind (stw, manoeuvre, draft): which fields follow", type=STRING),
    _f("stale", "bool", "true when the inputs stopped for longer than the estimator's stale_after", type=BOOL),
    _f("age", "s", "data time since the newest input the estimator received"),
    _f("converging", "bool", "true while the filter has not converged (after a start or a restart): "
       "its σ says how far to trust it", type=BOOL),
)

ESTIMATE_KINDS: dict[str, EstimateKind] = {
    k.name: k
    for k in (
        EstimateKind(
            "stw",
            "Speed through water from GNSS, IMU and current, never from the Doppler log (seed 000).",
            (
                _f("stw", "m/s", "speed through water (magnitude)", std="stw_std", truth="stw",
                   baseline=("water_speed", "stw_long"), derived=("naive_stw",)),
                _f("stw_std", "m/s", "1-σ of stw"),
                _f("sog", "m/s", "speed over ground (filtered)", truth="sog", baseline=("velocity_ground", "sog")),
                _n("current", "m/s", "current speed (drift) used by the filter"),
                _n("distance", "m", "distance travelled over ground since start"),
                _n("dvl_stw", "m/s", "the Doppler log's reading, kept for comparison only"),
                _n("stw_long", "m/s", "along-ship speed through water (null in paper mode)", truth="stw_long",
                   baseline=("water_speed", "stw_long")),
                _n("stw_trans", "m/s", "athwartship speed through water, + to starboard (null in paper mode)",
                   truth="stw_trans"),
                _f("mode", "name", "paper or vector", type=STRING),
                _n("current_set", "rad", "direction the current flows toward", angle=True, truth="current_set"),
                _n("current_along", "m/s", "current along the track, + following", truth="current_along"),
                _n("dvl_bias", "m/s", "the log's offset b in dvl = (1 + k)·stw + b"),
                _n("dvl_scale", "1", "the log's scale 1 + k (1 = no error)"),
                _f("dvl_std", "object", "1-σ of dvl_bias and dvl_scale ({bias, scale}); null without a log",
                   type=OBJECT, nullable=True),
            ),
        ),
        EstimateKind(
            "manoeuvre",
            "Manoeuvring state: kinematic CTRA/CMM with EKF/UKF/EnKF (seeds 002, 001, 004).",
            (
                _f("lat", "deg", "latitude (WGS-84)"),
                _f("lon", "deg", "longitude (WGS-84)"),
                _f("x", "m", "north in the estimator's own tangent plane (scored through lat, lon)", std="std.x"),
                _f("y", "m", "east in the estimator's own tangent plane (scored through lat, lon)", std="std.y"),
                _f("u", "m/s", "surge speed (body x)", std="std.u", truth="u"),
                _f("v", "m/s", "sway speed (body y, + starboard)", std="std.v", truth="v"),
                _f("r", "rad/s", "yaw rate, + to starboard", std="std.r", truth="r", baseline=("yaw_rate", "r")),
                _f("heading", "rad", "true heading", angle=True, std="std.heading", truth="heading",
                   baseline=("heading", "heading")),
                _f("a_u", "m/s^2", "surge acceleration", std="std.a_u", truth="a_u"),
                _f("a_v", "m/s^2", "sway acceleration", std="std.a_v", truth="a_v"),
                _f("sog", "m/s", "speed over ground", truth="sog", baseline=("velocity_ground", "sog")),
                _f("cog", "rad", "course over ground", angle=True, truth="cog", baseline=("velocity_ground", "cog")),
                _f("drift_angle", "rad", "atan2(v, u): drift over ground", angle=True, truth="drift_angle"),
                _n("drift_angle_water", "rad", "drift through the water (null without a known current)"),
                _n("nis", "1", "normalised innovation squared of the latest update"),
                _n("rcond", "1", "reciprocal condition number of that update's innovation covariance (eq. 23)"),
                _f("q_scale", "object", "process-noise scale of the NIS adaptation per group (yaw, translation)",
                   type=OBJECT),
                _f("mode", "name", "tuned or paper", type=STRING),
                _n("accel_bias", "m/s^2", "accelerometer biases [b_x, b_y] (null without bias states)", type=ARRAY),
                _f("model", "name", "ctra or cmm", type=STRING),
                _f("filter", "name", "ekf, ukf or enkf", type=STRING),
                _f("std", "object", "1-σ per state, keyed by field name", type=OBJECT),
                _f("predicted", "list", "[{dt, lat, lon, heading, std_major, std_minor, std_angle}] per horizon",
                   type=ARRAY),
            ),
        ),
        EstimateKind(
            "draft",
            "Draft at six marks with trim, list, deflection, squat and under-keel clearance (seed 003).",
            (
                _f("marks", "object", "per mark: draft, mean, rate, amplitude, std, ok", type=OBJECT),
                _n("mean_draft", "m", "mean of the marks' wave-free means", std="mean_draft_std", truth="mean_draft"),
                _n("mean_draft_std", "m", "1-σ of mean_draft"),
                _f("filled", "list", "marks out whose mean the derived values take from their partner and the list",
                   type=ARRAY),
                _n("trim", "m", "aft − fore, + by the stern", truth="trim"),
                _n("list", "m", "port − starboard", truth="list"),
                _n("heel", "rad", "heel angle (when the beam is configured)"),
                _n("deflection", "m", "mid − mean(fore, aft), + sagging", truth="deflection"),
                _n("squat", "m", "Barrass squat from the STW estimate", std="squat_std", truth="squat"),
                _n("squat_std", "m", "1-σ of squat, from the STW estimate's"),
                _n("ukc", "m", "under-keel clearance (when depth is measured)", truth="ukc"),
                _n("displacement_change", "t", "since the reference moment (null without TPC)",
                   std="displacement_change_std"),
                _n("displacement_change_std", "t", "1-σ of displacement_change"),
                _n("cargo_rate", "t/h", "rate of displacement change (null without TPC)", std="cargo_rate_std"),
                _n("cargo_rate_std", "t/h", "1-σ of cargo_rate"),
            ),
            mark_fields=(
                _n("draft", "m", "instantaneous filtered draft", std="std", truth="draft_{mark}",
                   baseline=("draft", "draft")),
                _n("mean", "m", "draft with the wave motion removed", truth="draft_{mark}_mean",
                   baseline=("draft", "draft")),
                _n("rate", "m/s", "rate of change of the draft"),
                _n("amplitude", "m", "amplitude of the wave-induced oscillation"),
                _n("std", "m", "1-σ of draft"),
                _f("ok", "bool", "false when the mark's sensor is excluded (fault, silence, jump)", type=BOOL),
            ),
        ),
    )
}


def estimate_to_json(e: Estimate) -> dict[str, Any]:
    """The JSON object of an estimate, the same for every output (DESIGN §6, §7).

    `{"t", "kind", "stale", "age", "converging", <values>}`; the record's `t` wins over
    a value named `t`; `stale`/`age` default to false/0 for estimates made outside a
    worker host (tests, tools), and `converging` to false for a core that does not
    set it.
    """
    d: dict[str, Any] = {"t": e.t, "kind": e.kind, "stale": False, "age": 0.0, "converging": False}
    d.update(e.values)
    d["t"] = e.t
    return d


def kinds_markdown() -> str:
    """The estimate kinds as a Markdown section (the docs are made from here)."""
    lines = ["Every estimate: " + ", ".join(f"`{f.name}` ({f.unit}: {f.doc})" for f in COMMON_FIELDS) + "."]
    for kind in ESTIMATE_KINDS.values():
        lines += ["", f"`{kind.name}`: {kind.doc}", "", "| field | unit | null | meaning |", "|---|---|---|---|"]
        for f in kind.fields:
            lines.append(f"| `{f.name}` | {f.unit} | {'yes' if f.nullable else ''} | {f.doc} |")
        for f in kind.mark_fields:
            lines.append(f"| `marks.<mark>.{f.name}` | {f.unit} | {'yes' if f.nullable else ''} | {f.doc} |")
    return "\n".join(lines) + "\n"
