"""Estimates against truth: the rows of `edged score` (DESIGN §4, ESTIMATORS "Evaluation").

Per scored field of every `/est/<name>` channel (`edged.estimates`: its truth column,
σ and the sensor it replaces) one row of `figures.Figures`; under it, judged by the
same rules, a row per source of the raw sensor it replaces and per derived baseline
(`baselines`), and for a kind with `lat`/`lon` a `position` row (metres) with the
position sensors under it. Pure: the command feeds a `recording.Recording` and a
`truth.Truth`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any, Iterable, Iterator

import numpy as np

from edged.estimates import ESTIMATE_KINDS, ScoredField

from .baselines import DERIVED
from .columns import Series
from .figures import LAGS, SIGMAS, Figures, field_errors, figures, position_errors
from .recording import Recording, has_position
from .truth import ScoreError, Truth

__all__ = ["POSITION", "Row", "Score", "score"]

#: The `field` of the horizontal position row (from `lat`/`lon`, in metres).
POSITION = "position"
_POSITION_UNIT = "m"


@dataclass(frozen=True)
class Row:
    """One line of the score table: an estimate's field, or a sensor under it."""

    estimate: str
    kind: str
    field: str
    truth: str
    unit: str
    figures: Figures
    #: For a sensor's row: the measurement topic and field it is read from; for a
    #: derived baseline's row: its label (`DERIVED`) and the topics it is made from.
    baseline: str | None = None
    baseline_field: str | None = None

    def to_json(self) -> dict[str, Any]:
        f = self.figures
        d: dict[str, Any] = {
            "estimate": self.estimate,
            "kind": self.kind,
            "field": self.field,
            "truth": self.truth,
            "unit": self.unit,
            "baseline": self.baseline,
            "baseline_field": self.baseline_field,
            "n": f.n,
            "rmse": f.rmse,
            "bias": f.bias,
            "max_abs": f.max_abs,
            "n_sigma": f.n_sigma,
        }
        d.update({f"pct_{k}sigma": w for k, w in zip(SIGMAS, f.within)})
        d.update({f"ac{k}": a for k, a in zip(LAGS, f.ac)})
        return d


@dataclass
class Score:
    rows: list[Row]
    #: What the user should know but is no error (unscorable kinds, missing columns).
    notes: list[str]


@dataclass(frozen=True)
class _Plan:
    """What is scored of one (estimate, kind): its fields with a truth column, and
    whether its position is."""

    name: str
    kind: str
    series: Series
    fields: list[ScoredField]
    position: bool


def _utc(t: float) -> str:
    try:
        return datetime.fromtimestamp(t, tz=timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    except (OverflowError, OSError, ValueError):  # a time no calendar holds: say it as it is
        return f"t={t:.3f}"


def _baseline_rows(rec: Recording, truth: Truth, est: str, kind: str, f: ScoredField, start: float) -> Iterator[Row]:
    """The raw measurement a field replaces, one row per source, judged like it."""
    if f.baseline is None:
        return
    mkind, mfield = f.baseline
    for topic in rec.topics_of(mkind):
        c = rec.measurements[topic].columns()
        v = c.values[mfield]
        if f.baseline_mark is not None:
            v = np.where(c.mark == f.baseline_mark, v, math.nan)
        if not np.isfinite(v).any():
            continue  # this source does not measure it (another draft mark, no value)
        err, _ = field_errors(truth, f.truth, c.t, np.where(c.t >= start, v, math.nan), f.angle)
        yield Row(est, kind, f.path, f.truth, f.unit, figures(err), topic, mfield)


def _derived_rows(rec: Recording, truth: Truth, est: str, kind: str, f: ScoredField, start: float) -> Iterator[Row]:
    """The derived baselines of a field, one row per combination of input sources,
    judged like a sensor (same warm-up start and truth span)."""
    for name in f.derived:
        d = DERIVED[name]
        for topics in itertools.product(*(rec.topics_of(mkind) for mkind, _ in d.inputs)):
            args: list[np.ndarray] = []
            for topic, (_, mfields) in zip(topics, d.inputs):
                c = rec.measurements[topic].columns()
                args += [c.t, *(c.values[m] for m in mfields)]
            t = args[0]
            v = d.compute(*args)
            if not np.isfinite(v).any():
                continue  # nothing to judge (no sample after the first forecast)
            err, _ = field_errors(truth, f.truth, t, np.where(t >= start, v, math.nan), f.angle)
            yield Row(est, kind, f.path, f.truth, f.unit, figures(err), d.label, ", ".join(topics))


def _position_baselines(rec: Recording, truth: Truth, est: str, kind: str, start: float) -> Iterator[Row]:
    for topic in rec.topics_of("position"):
        c = rec.measurements[topic].columns()
        lat = np.where(c.t >= start, c.values["lat"], math.nan)
        err, _ = position_errors(truth, c.t, lat, c.values["lon"])
        yield Row(est, kind, POSITION, "lat,lon", _POSITION_UNIT, figures(err), topic, "lat,lon")


def _selected(rec: Recording, only: Iterable[str] | None) -> set[str]:
    """The estimate names to score: all, or those asked for (which must exist)."""
    if not rec.names:
        raise ScoreError(f"{rec.name}: no estimates (no /est/<name> channels)")
    selected = set(rec.names)
    if only:
        wanted = set(only)
        unknown = sorted(wanted - selected)
        if unknown:
            raise ScoreError(f"{rec.name}: no estimate named {', '.join(unknown)} (estimates: {', '.join(rec.names)})")
        selected = wanted
    return selected


def _unscorable_notes(rec: Recording, selected: set[str]) -> list[str]:
    notes = []
    for name in sorted(selected & set(rec.unscorable)):
        for kind, n in sorted(rec.unscorable[name].items(), key=lambda kv: str(kv[0])):
            what = "null" if kind is None else repr(kind)
            notes.append(f"{rec.name}: /est/{name}: {n} message(s) of kind {what}: not scorable (no such estimate kind)")
    return notes


def _plans(rec: Recording, truth: Truth, selected: set[str], notes: list[str]) -> list[_Plan]:
    """What each selected estimate can be scored on with this truth; a note for the
    truth columns that are missing, ScoreError when nothing at all can be."""
    groups = [(name, kind, s) for (name, kind), s in sorted(rec.estimates.items()) if name in selected]
    if not groups:
        kinds = sorted({"null" if k is None else repr(k) for n in selected for k in rec.unscorable.get(n, {})})
        raise ScoreError(
            f"{rec.name}: no estimate of a kind edged defines ({', '.join(ESTIMATE_KINDS)}) to score; "
            f"the estimates have kind {', '.join(kinds)}"
        )
    missing: set[str] = set()
    plans: list[_Plan] = []
    for name, kind, s in groups:
        spec = ESTIMATE_KINDS[kind]
        fields = [f for f in spec.scored_fields() if f.truth in truth.columns]
        missing |= {f.truth for f in spec.scored_fields() if f.truth not in truth.columns}
        position = has_position(spec) and {"lat", "lon"} <= set(truth.columns)
        if has_position(spec) and not position:
            missing |= {"lat", "lon"} - set(truth.columns)
        plans.append(_Plan(name, kind, s, fields, position))
    if not any(p.fields or p.position for p in plans):
        raise ScoreError(f"{truth.name}: none of the columns the estimates are scored against ({', '.join(sorted(missing))})")
    if missing:
        notes.append(f"{truth.name}: no column {', '.join(sorted(missing))}: those fields are not scored")
    return plans


def _check_overlap(rec: Recording, truth: Truth, plans: list[_Plan]) -> None:
    t_all = np.concatenate([np.asarray(p.series.t) for p in plans])
    if not truth.covers(t_all).any():
        lo, hi = truth.span
        raise ScoreError(
            f"{rec.name} (estimates {_utc(t_all.min())} .. {_utc(t_all.max())}) and {truth.name} "
            f"({_utc(lo)} .. {_utc(hi)}): no overlapping time"
        )


def _rows(rec: Recording, truth: Truth, p: _Plan, warmup: float) -> Iterator[Row]:
    """The rows of one estimate: position first, then each field, sensors under each."""
    c = p.series.columns()
    t, vals = c.t, c.values
    start = rec.first_t[p.name] + warmup
    out = (t < start) | c.stale
    if p.position:
        lat = np.where(out, math.nan, vals["lat"])
        err, _ = position_errors(truth, t, lat, vals["lon"])
        yield Row(p.name, p.kind, POSITION, "lat,lon", _POSITION_UNIT, figures(err))
        yield from _position_baselines(rec, truth, p.name, p.kind, start)
    for f in p.fields:
        err, idx = field_errors(truth, f.truth, t, np.where(out, math.nan, vals[f.path]), f.angle)
        sigma = vals[f.std][idx] if f.std else None
        yield Row(p.name, p.kind, f.path, f.truth, f.unit, figures(err, sigma))
        yield from _baseline_rows(rec, truth, p.name, p.kind, f, start)
        yield from _derived_rows(rec, truth, p.name, p.kind, f, start)


def score(rec: Recording, truth: Truth, warmup: float, only: Iterable[str] | None = None) -> Score:
    """Every scorable field of every (selected) estimate against truth, with its sensors.

    Left out of every figure: estimates before the channel's first estimate + `warmup`
    seconds (a filter converging is not its accuracy), stale ones (`stale: true`), null
    values, and anything outside the truth's time span. Sensors get the same warm-up
    (from the estimate's start) and span, so the rows compare like with like.
    """
    selected = _selected(rec, only)
    notes = _unscorable_notes(rec, selected)
    plans = _plans(rec, truth, selected, notes)
    _check_overlap(rec, truth, plans)
    rows = [row for p in plans for row in _rows(rec, truth, p, warmup)]
    if not any(r.figures.n for r in rows if r.baseline is None):
        raise ScoreError(
            f"{rec.name}: nothing left to score after the {warmup:g} s warm-up "
            "(stale estimates, null values and times outside the truth are left out too)"
        )
    return Score(rows, notes)
