"""The estimate kinds: what each estimate's fields are (DESIGN §6).

Beside the measurement kinds of `edged.records`, an estimate kind says what an
estimator publishes: every field's name, SI unit, JSON type, whether it may be null,
and, for `edged score`, the truth column it is judged against, the field that carries
its 1-σ and the measurement it replaces (so that "better than the sensor" is one
table). The MCAP channel schemas, the Zenoh/MCAP payload (`estimate_to_json`) and the
docs (`kinds_markdown`) are all made from here.

The core defines no kind: each estimator's package declares its own `EstimateKind`
(e.g. `edged_stw/estimate.py`) and registers it in the entry point group
`edged.estimate_kinds` under the kind's name. `ESTIMATE_KINDS` loads them on its first
use (one scan of the installed packages' metadata, in each process that asks);
`register_kind` adds one by hand (tests, embedding).

An estimate is published under its estimator instance's name (`[estimators.stw_paper]`
-> `est/stw_paper`); its *kind* (`stw`) says which fields it has. Every kind has the
common fields `t`, `kind`, `stale`, `age` and `converging`.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any

from .records import Estimate

log = logging.getLogger("edged.estimates")

__all__ = [
    "EstField",
    "EstimateKind",
    "ScoredField",
    "ESTIMATE_KINDS",
    "KINDS_GROUP",
    "COMMON_FIELDS",
    "est_field",
    "nullable_field",
    "register_kind",
    "estimate_to_json",
    "kinds_markdown",
]

#: The entry point group of the estimate kinds: name = the kind's, object = its
#: `EstimateKind`.
KINDS_GROUP = "edged.estimate_kinds"

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
    `edged_analysis.baselines.DERIVED`.
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
    """The fields of one estimate kind, declared by the estimator package that makes it."""

    name: str
    doc: str
    fields: tuple[EstField, ...]
    #: Per-mark fields: the kind's `marks` object holds one object of these per name
    #: of `marks` (the draft kind's six draft marks).
    mark_fields: tuple[EstField, ...] = ()
    marks: tuple[str, ...] = ()

    @property
    def field_names(self) -> tuple[str, ...]:
        return tuple(f.name for f in COMMON_FIELDS + self.fields)

    def scored_fields(self) -> Iterator[ScoredField]:
        """Every value of this kind that has a truth column, with its σ and baseline."""
        for f in self.fields:
            if f.truth is not None:
                yield ScoredField(f.name, f.truth, f.unit, f.angle, f.std, f.baseline, derived=f.derived)
        for mark in self.marks if self.mark_fields else ():
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


def est_field(name: str, unit: str, doc: str, **kw: Any) -> EstField:
    """A field (a number unless `type` says otherwise) that is never null."""
    return EstField(name, unit, doc, **kw)


def nullable_field(name: str, unit: str, doc: str, **kw: Any) -> EstField:
    """A number that may be null (not known, not configured)."""
    return EstField(name, unit, doc, nullable=True, **kw)


#: Fields every estimate has. `t` is the record's time and always wins over a value
#: of the same name; `stale`/`age` are set by the worker host, not by the core;
#: `converging` by the core.
COMMON_FIELDS: tuple[EstField, ...] = (
    est_field("t", "s", "time the estimate is valid for, UTC seconds (UNIX epoch)"),
    est_field("kind", "name", "estimate kind (stw, manoeuvre, draft): which fields follow", type=STRING),
    est_field("stale", "bool", "true when the inputs stopped for longer than the estimator's stale_after", type=BOOL),
    est_field("age", "s", "data time since the newest input the estimator received"),
    est_field("converging", "bool", "true while the filter has not converged (after a start or a restart): "
              "its σ says how far to trust it", type=BOOL),
)


class _Kinds(Mapping[str, EstimateKind]):
    """The estimate kinds by name: the entry points of `KINDS_GROUP` in their
    packages' order, loaded on first use, and those registered by hand (which win). A kind that fails to
    load, or whose entry point's name is not its own, is logged and left out: a broken
    third-party package must not stop edged."""

    def __init__(self) -> None:
        self._loaded: dict[str, EstimateKind] | None = None
        self._registered: dict[str, EstimateKind] = {}
        self._all: dict[str, EstimateKind] | None = None  # the two merged

    def _load(self) -> dict[str, EstimateKind]:
        loaded: dict[str, EstimateKind] = {}
        for ep in entry_points(group=KINDS_GROUP):
            if ep.name in loaded:
                continue
            try:
                kind = ep.load()
            except Exception as exc:
                log.warning("estimate kind %s failed to load: %s", ep.name, exc)
                continue
            if not isinstance(kind, EstimateKind) or kind.name != ep.name:
                log.warning("estimate kind %s: %s is not an EstimateKind named so", ep.name, ep.value)
                continue
            loaded[ep.name] = kind
        return loaded

    def _kinds(self) -> dict[str, EstimateKind]:
        merged = self._all
        if merged is None:
            if self._loaded is None:
                self._loaded = self._load()
            merged = self._all = {**self._loaded, **self._registered}
        return merged

    def __getitem__(self, name: str) -> EstimateKind:
        return self._kinds()[name]

    def __contains__(self, name: object) -> bool:
        return name in self._kinds()

    def __iter__(self) -> Iterator[str]:
        return iter(self._kinds())

    def __len__(self) -> int:
        return len(self._kinds())

    def register(self, kind: EstimateKind) -> None:
        self._registered[kind.name] = kind
        self._all = None


#: Every estimate kind installed, by name (lazily filled: see `_Kinds`).
ESTIMATE_KINDS: Mapping[str, EstimateKind] = _Kinds()


def register_kind(kind: EstimateKind) -> None:
    """Add (or replace) a kind by hand, beside the installed ones (tests, embedding)."""
    ESTIMATE_KINDS.register(kind)  # type: ignore[attr-defined]


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
