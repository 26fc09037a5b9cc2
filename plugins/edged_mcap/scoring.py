"""Estimates against truth: the figures of `edged score` (DESIGN §4, ESTIMATORS "Evaluation").

Pure functions and plain containers, no file access: the command feeds payloads from
a recording and a text stream of the truth table, so all of it is testable without
files and the figures are the same whoever reads the inputs.

The truth table (`truth.csv`)
-----------------------------
CSV text, comma-separated, with a header row naming the columns.

- `t` (required): the instant the row is true for, UNIX seconds (UTC), the same time
  base as the estimates' `t`. Rows need not be sorted.
- Every other column is a number named as in `ScoredField.truth` of
  `edged.estimates` and in the same units as the estimate fields (SI: m, m/s, m/s²,
  rad, rad/s; `lat`/`lon` in degrees). The simulator (`edged sim`) writes exactly
  these, in the order of `edged_sim.truth.columns()`: `t, t_rel, lat, lon, x, y, u, v,
  r, heading, a_u, a_v, sog, cog, drift_angle, stw, stw_long, stw_trans, current_set,
  current_drift, current_along, current_cross, ax, ay, az, roll, pitch, heave,
  roll_rate, pitch_rate, rudder, rudder_order, thrust_speed, depth,
  depth_below_transducer, squat, ukc, mean_draft, trim, list, deflection` and per
  draft mark `draft_<mark>`, `draft_<mark>_mean`.
- So any CSV with a `t` column works (a trials log, a reference GNSS): columns nobody
  is scored against are ignored, and a field whose column is missing is not scored
  (and said so).
- An empty cell, `nan` or an infinity means "truth unknown" at that row. A row with
  a cell that is not a number, a `t` that is not finite, or the wrong number of cells
  is skipped and counted (`Truth.bad_rows`); blank lines are ignored.

Truth is interpolated linearly to each estimate's own time; angles on the unwrapped
angle (so 359° → 1° passes through 0°, not 180°), and an angle's error is wrapped to
(−π, π]. Errors are `estimate − truth`.

An estimate kind with `lat`/`lon` (the manoeuvre kind) also gets a `position` row: the
horizontal distance from the true position in metres (see `position_errors`). A
distance has no sign, so its "bias" is the mean distance, and it has no ±kσ figures
(a 2-D error is judged against an ellipse, not a 1-D σ).

Derived baselines (`EstField.derived`, computed here by `DERIVED`) are scored like a
sensor: `naive_stw`, beside `stw`, is what a crew does without a filter or a log they
trust: at each SOG/COG measurement, SOG − drift·cos(set − COG) with the latest current
measurement at or before it (none before the first one). One row per pair of a
`/meas/velocity_ground/<source>` and a `/meas/current/<source>` topic (sources are not
mixed); a recording without either has no such row.
"""

from __future__ import annotations

import csv
import itertools
import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import Any, Callable, Iterable, Iterator, TextIO

import numpy as np

from edged.estimates import ESTIMATE_KINDS, EstimateKind, ScoredField

__all__ = [
    "EARTH_RADIUS",
    "LAGS",
    "SIGMAS",
    "POSITION",
    "ScoreError",
    "Truth",
    "load_truth",
    "wrap",
    "Figures",
    "figures",
    "autocorrelation",
    "field_errors",
    "position_errors",
    "Columns",
    "Series",
    "Recording",
    "Row",
    "Score",
    "score",
    "Derived",
    "DERIVED",
    "naive_stw",
]

EARTH_RADIUS = 6_371_008.8  # m, mean radius (IUGG)
#: Lags (in samples) of the error autocorrelation: white errors give ≈ 0 at each.
LAGS: tuple[int, ...] = (1, 10, 60)
#: σ multiples of the coverage figures: a consistent σ gives 68.3 / 95.4 / 99.7 %.
SIGMAS: tuple[int, ...] = (1, 2, 3)
#: The `field` of the horizontal position row (from `lat`/`lon`, in metres).
POSITION = "position"
_POSITION_UNIT = "m"


class ScoreError(ValueError):
    """Input that cannot be scored; the message names the file and says why."""


# -- truth ------------------------------------------------------------------------
@dataclass
class Truth:
    """The truth table as columns, sorted by `t`."""

    name: str
    t: np.ndarray
    columns: dict[str, np.ndarray]
    bad_rows: int = 0

    @property
    def span(self) -> tuple[float, float]:
        return float(self.t[0]), float(self.t[-1])

    def covers(self, t: np.ndarray) -> np.ndarray:
        """Which instants lie inside the table's time span (no extrapolation)."""
        return (t >= self.t[0]) & (t <= self.t[-1])

    def at(self, column: str, t: np.ndarray, period: float | None = None) -> np.ndarray:
        """`column` linearly interpolated to `t`; NaN next to an unknown truth value.

        `period` (2π for angles, 360 for longitude) interpolates the unwrapped values,
        so that a crossing of north is a small step and not a swing the other way round.
        """
        y = self.columns[column]
        if period is not None:
            y = y.copy()
            ok = np.isfinite(y)  # np.unwrap would spread one NaN to every later value
            y[ok] = np.unwrap(y[ok], period=period)
        return np.interp(t, self.t, y)


def load_truth(stream: TextIO, name: str) -> Truth:
    """Read a truth table (format in the module docstring) from a text stream.

    Raises ScoreError naming `name` when there is no `t` column or no usable row.
    """
    reader = csv.reader(stream)
    try:
        header = next((row for row in reader if any(c.strip() for c in row)), None)
        if header is None:
            raise ScoreError(f"{name}: empty truth table (a header row with a 't' column is needed)")
        header = [h.strip() for h in header]
        header[0] = header[0].lstrip("\ufeff").strip()  # a byte-order mark (spreadsheet export)
        if "t" not in header:
            shown = ", ".join(header[:8]) + (", ..." if len(header) > 8 else "")
            raise ScoreError(f"{name}: no 't' column (UNIX seconds) in the header: {shown}")
        ti, width = header.index("t"), len(header)
        good: list[list[float]] = []
        bad = 0
        for row in reader:
            if not any(c.strip() for c in row):
                continue
            if len(row) != width:
                bad += 1
                continue
            try:
                vals = [float(c) if c.strip() else math.nan for c in row]
            except ValueError:
                bad += 1
                continue
            if not math.isfinite(vals[ti]):
                bad += 1
                continue
            good.append(vals)
    except csv.Error as exc:
        raise ScoreError(f"{name}: line {reader.line_num}: not CSV ({exc})") from None
    except UnicodeDecodeError:
        raise ScoreError(f"{name}: not a text file (a CSV truth table is expected)") from None
    if not good:
        raise ScoreError(f"{name}: no numeric rows" + (f" ({bad} bad rows skipped)" if bad else ""))
    table = np.array(good, dtype=float)
    table = table[np.argsort(table[:, ti], kind="stable")]
    table[~np.isfinite(table)] = math.nan
    columns = {h: table[:, i] for i, h in enumerate(header) if h}
    return Truth(name, table[:, ti], columns, bad)


# -- errors and their figures -------------------------------------------------------
def wrap(e: np.ndarray, period: float = 2.0 * math.pi) -> np.ndarray:
    """Differences of angles onto (−period/2, period/2]: 1° − 359° is +2°, not −358°."""
    half = 0.5 * period
    return half - np.mod(half - e, period)


def field_errors(
    truth: Truth, column: str, t: np.ndarray, v: np.ndarray, angle: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Errors `v − truth` at the samples that can be judged, and those samples' indices.

    A sample is judged when its value is known (finite), its time lies in the truth's
    span and the interpolated truth is known; callers blank (NaN) what they leave out.
    """
    keep = np.flatnonzero(np.isfinite(v) & truth.covers(t))
    ref = truth.at(column, t[keep], 2.0 * math.pi if angle else None)
    ok = np.isfinite(ref)
    idx = keep[ok]
    err = v[idx] - ref[ok]
    return (wrap(err) if angle else err), idx


def position_errors(
    truth: Truth, t: np.ndarray, lat: np.ndarray, lon: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal distance (m) from the true position at each sample, and the indices.

    Equirectangular approximation about the truth point: north = Δlat·R, east =
    Δlon·R·cos(lat_truth), R the mean Earth radius. For errors of metres to a few
    kilometres this is within about 0.5 % of the geodesic (the ellipsoid's radii
    differ from the mean by that much), far below what separates two estimators.
    """
    keep = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon) & truth.covers(t))
    tlat = truth.at("lat", t[keep])
    tlon = truth.at("lon", t[keep], 360.0)  # unwrapped: a track across the antimeridian
    ok = np.isfinite(tlat) & np.isfinite(tlon)
    idx = keep[ok]
    tlat = tlat[ok]
    north = np.radians(lat[idx] - tlat) * EARTH_RADIUS
    east = np.radians(wrap(lon[idx] - tlon[ok], 360.0)) * EARTH_RADIUS * np.cos(np.radians(tlat))
    return np.hypot(north, east), idx


@dataclass(frozen=True)
class Figures:
    """What one error series says. None where a figure does not apply (no samples,
    no σ, a series shorter than the lag, a constant error)."""

    n: int
    rmse: float | None = None
    bias: float | None = None
    max_abs: float | None = None
    #: Samples with a σ (None: the field has no σ at all).
    n_sigma: int | None = None
    #: % of errors inside ±kσ for k in SIGMAS (of the n_sigma samples).
    within: tuple[float | None, ...] = (None,) * len(SIGMAS)
    #: Error autocorrelation at each of LAGS.
    ac: tuple[float | None, ...] = (None,) * len(LAGS)


def autocorrelation(x: np.ndarray, lag: int) -> float | None:
    """Sample autocorrelation r_k = Σ(x_i − x̄)(x_{i+k} − x̄) / Σ(x_i − x̄)².

    The usual (biased) estimator of a correlogram: bounded by 1, and for a white
    series |r_k| stays below about 2/√n. None when the series is not longer than the
    lag or does not vary (a constant error has no correlation to speak of; variation
    below 1e-9 of the error's size is rounding, not signal).
    """
    if lag < 1 or x.size <= lag:
        return None
    d = x - x.mean()
    den = float(d @ d)
    if den <= x.size * (1e-9 * float(np.abs(x).max())) ** 2:
        return None
    return float(d[:-lag] @ d[lag:]) / den


def figures(err: np.ndarray, sigma: np.ndarray | None = None) -> Figures:
    """The figures of an error series in time order; `sigma` the 1-σ at each sample
    (NaN where unknown: that sample is left out of the coverage only)."""
    n = int(err.size)
    n_sigma: int | None = None if sigma is None else 0
    if n == 0:
        return Figures(0, n_sigma=n_sigma)
    a = np.abs(err)
    within: tuple[float | None, ...] = (None,) * len(SIGMAS)
    if sigma is not None:
        ok = np.isfinite(sigma) & (sigma >= 0.0)
        n_sigma = int(ok.sum())
        if n_sigma:
            within = tuple(100.0 * float(np.mean(a[ok] <= k * sigma[ok])) for k in SIGMAS)
    return Figures(
        n,
        rmse=float(np.sqrt(np.mean(err * err))),
        bias=float(np.mean(err)),
        max_abs=float(a.max()),
        n_sigma=n_sigma,
        within=within,
        ac=tuple(autocorrelation(err, k) for k in LAGS),
    )


# -- the recording as columns ----------------------------------------------------------
def _num(v: Any) -> float:
    """A JSON value as a float; NaN for null, absent, text, booleans, non-finite."""
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        try:
            f = float(v)
        except OverflowError:  # an integer beyond any float
            return math.nan
        return f if math.isfinite(f) else math.nan
    return math.nan


def _get(payload: dict[str, Any], path: str) -> Any:
    """The value at a dotted path (`std.u`, `marks.fore_port.mean`), None if absent."""
    v: Any = payload
    for key in path.split("."):
        if not isinstance(v, dict):
            return None
        v = v.get(key)
    return v


def _has_position(kind: EstimateKind) -> bool:
    return {"lat", "lon"} <= set(kind.field_names)


def _estimate_paths(kind: EstimateKind) -> tuple[str, ...]:
    paths: dict[str, None] = {}
    for f in kind.scored_fields():
        paths[f.path] = None
        if f.std:
            paths[f.std] = None
    if _has_position(kind):
        paths.update(dict.fromkeys(("lat", "lon")))
    return tuple(paths)


# -- derived baselines ----------------------------------------------------------------
def naive_stw(
    t_v: np.ndarray, sog: np.ndarray, cog: np.ndarray, t_c: np.ndarray, set_: np.ndarray, drift: np.ndarray
) -> np.ndarray:
    """SOG − the latest current forecast along the course, at each velocity sample.

    `t_v`, `sog` (m/s), `cog` (rad): the velocity_ground measurements; `t_c`, `set_`
    (rad, the direction the current flows toward), `drift` (m/s): the current
    measurements, both in time order. At `t_v[i]` the forecast used is the latest
    one with `t_c ≤ t_v[i]` (a forecast that arrives later is not known yet); a
    forecast without set or drift is no forecast. NaN before the first forecast and
    where SOG or COG is unknown.
    """
    ok = np.isfinite(t_c) & np.isfinite(set_) & np.isfinite(drift)
    t_c, set_, drift = t_c[ok], set_[ok], drift[ok]
    out = np.full(t_v.shape, math.nan)
    if t_c.size == 0:
        return out
    j = np.searchsorted(t_c, t_v, side="right") - 1
    has = j >= 0
    jj = j[has]
    out[has] = sog[has] - drift[jj] * np.cos(set_[jj] - cog[has])
    return out


@dataclass(frozen=True)
class Derived:
    """A baseline computed from measurements: its label, inputs and computation.

    `inputs`: (measurement kind, fields) in the order `compute` takes them, each
    source as its times then those fields' arrays; the first input's times are the
    baseline's. One row is made per combination of the kinds' sources.
    """

    label: str
    inputs: tuple[tuple[str, tuple[str, ...]], ...]
    compute: Callable[..., np.ndarray]


#: Derived baselines by the name `EstField.derived` gives them. Labels are ASCII
#: (the table is read on any terminal).
DERIVED: dict[str, Derived] = {
    "naive_stw": Derived(
        "naive: sog - forecast along course",
        (("velocity_ground", ("sog", "cog")), ("current", ("set", "drift"))),
        naive_stw,
    ),
}


def _baseline_fields() -> dict[str, tuple[str, ...]]:
    """Measurement kind -> the fields some estimate is compared with, directly or
    through a derived baseline (and positions)."""
    out: dict[str, dict[str, None]] = {"position": {"lat": None, "lon": None}}
    for kind in ESTIMATE_KINDS.values():
        for f in kind.scored_fields():
            if f.baseline:
                out.setdefault(f.baseline[0], {})[f.baseline[1]] = None
            for name in f.derived:
                for mkind, mfields in DERIVED[name].inputs:
                    out.setdefault(mkind, {}).update(dict.fromkeys(mfields))
    return {k: tuple(v) for k, v in out.items()}


_BASELINE_FIELDS = _baseline_fields()


@dataclass(frozen=True)
class Columns:
    """A channel's messages as arrays, sorted by time (file order is publish order)."""

    t: np.ndarray
    stale: np.ndarray
    #: The `mark` of each message (draft measurements), None where there is none.
    mark: np.ndarray
    values: dict[str, np.ndarray]


@dataclass
class Series:
    """One channel's messages, collected value by value: NaN where null or absent."""

    paths: tuple[str, ...]
    t: list[float] = field(default_factory=list)
    stale: list[bool] = field(default_factory=list)
    mark: list[Any] = field(default_factory=list)
    values: dict[str, list[float]] = field(default_factory=dict)
    _columns: Columns | None = field(default=None, repr=False)

    def add(self, t: float, payload: dict[str, Any]) -> None:
        self._columns = None
        self.t.append(t)
        self.stale.append(payload.get("stale") is True)
        mark = payload.get("mark")
        self.mark.append(mark if isinstance(mark, str) else None)
        for p in self.paths:
            self.values.setdefault(p, []).append(_num(_get(payload, p)))

    def columns(self) -> Columns:
        """The arrays, made once (a sensor is the baseline of several fields)."""
        if self._columns is None:
            t = np.asarray(self.t, dtype=float)
            order = np.argsort(t, kind="stable")
            mark = np.empty(len(self.mark), dtype=object)
            mark[:] = self.mark
            vals = {p: np.asarray(self.values.get(p, [math.nan] * t.size), dtype=float)[order] for p in self.paths}
            self._columns = Columns(t[order], np.asarray(self.stale, dtype=bool)[order], mark[order], vals)
        return self._columns


class Recording:
    """The estimates and baseline measurements of a recording, fed one payload at a time.

    Estimates are kept per (channel name, kind); a kind edged does not define (or
    null) is only counted, to say that it was not scorable.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self.estimates: dict[tuple[str, str], Series] = {}
        self.unscorable: dict[str, dict[str | None, int]] = {}
        #: Per estimate name, its first message's time: the warm-up starts there.
        self.first_t: dict[str, float] = {}
        self.measurements: dict[str, Series] = {}
        #: Messages on wanted topics that are not a JSON object with a numeric `t`.
        self.undecodable = 0

    @staticmethod
    def wants(topic: str) -> bool:
        """Whether `topic` carries anything scored (saves decoding raw data)."""
        if topic.startswith("/est/"):
            return len(topic) > 5
        parts = topic.split("/", 3)
        return len(parts) == 4 and parts[1] == "meas" and parts[2] in _BASELINE_FIELDS and bool(parts[3])

    def add(self, topic: str, payload: Any) -> None:
        if not self.wants(topic):
            return
        t = _num(payload.get("t")) if isinstance(payload, dict) else math.nan
        if math.isnan(t):
            self.undecodable += 1
            return
        if topic.startswith("/est/"):
            self._add_estimate(topic[5:], t, payload)
            return
        s = self.measurements.get(topic)
        if s is None:
            s = self.measurements[topic] = Series(_BASELINE_FIELDS[topic.split("/", 3)[2]])
        s.add(t, payload)

    def _add_estimate(self, name: str, t: float, payload: dict[str, Any]) -> None:
        first = self.first_t.get(name)
        self.first_t[name] = t if first is None else min(first, t)
        kind = payload.get("kind")
        spec = ESTIMATE_KINDS.get(kind) if isinstance(kind, str) else None
        if spec is None:
            counts = self.unscorable.setdefault(name, {})
            key = kind if isinstance(kind, str) else None
            counts[key] = counts.get(key, 0) + 1
            return
        s = self.estimates.get((name, spec.name))
        if s is None:
            s = self.estimates[(name, spec.name)] = Series(_estimate_paths(spec))
        s.add(t, payload)

    @property
    def names(self) -> list[str]:
        return sorted(self.first_t)

    def topics_of(self, kind: str) -> list[str]:
        prefix = f"/meas/{kind}/"
        return sorted(t for t in self.measurements if t.startswith(prefix))


# -- scoring --------------------------------------------------------------------------
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


def score(rec: Recording, truth: Truth, warmup: float, only: Iterable[str] | None = None) -> Score:
    """Every scorable field of every (selected) estimate against truth, with its sensors.

    Left out of every figure: estimates before the channel's first estimate + `warmup`
    seconds (a filter converging is not its accuracy), stale ones (`stale: true`), null
    values, and anything outside the truth's time span. Sensors get the same warm-up
    (from the estimate's start) and span, so the rows compare like with like.
    """
    if not rec.names:
        raise ScoreError(f"{rec.name}: no estimates (no /est/<name> channels)")
    selected = set(rec.names)
    if only:
        wanted = set(only)
        unknown = sorted(wanted - selected)
        if unknown:
            raise ScoreError(f"{rec.name}: no estimate named {', '.join(unknown)} (estimates: {', '.join(rec.names)})")
        selected = wanted
    notes = []
    for name in sorted(selected & set(rec.unscorable)):
        for kind, n in sorted(rec.unscorable[name].items(), key=lambda kv: str(kv[0])):
            what = "null" if kind is None else repr(kind)
            notes.append(f"{rec.name}: /est/{name}: {n} message(s) of kind {what}: not scorable (no such estimate kind)")
    groups = [(name, kind, s) for (name, kind), s in sorted(rec.estimates.items()) if name in selected]
    if not groups:
        kinds = sorted({"null" if k is None else repr(k) for n in selected for k in rec.unscorable.get(n, {})})
        raise ScoreError(
            f"{rec.name}: no estimate of a kind edged defines ({', '.join(ESTIMATE_KINDS)}) to score; "
            f"the estimates have kind {', '.join(kinds)}"
        )

    missing: set[str] = set()
    plans: list[tuple[str, str, Series, list[ScoredField], bool]] = []
    for name, kind, s in groups:
        spec = ESTIMATE_KINDS[kind]
        fields = [f for f in spec.scored_fields() if f.truth in truth.columns]
        missing |= {f.truth for f in spec.scored_fields() if f.truth not in truth.columns}
        position = _has_position(spec) and {"lat", "lon"} <= set(truth.columns)
        if _has_position(spec) and not position:
            missing |= {"lat", "lon"} - set(truth.columns)
        plans.append((name, kind, s, fields, position))
    if not any(fields or position for *_, fields, position in plans):
        raise ScoreError(f"{truth.name}: none of the columns the estimates are scored against ({', '.join(sorted(missing))})")
    if missing:
        notes.append(f"{truth.name}: no column {', '.join(sorted(missing))}: those fields are not scored")

    t_all = np.concatenate([np.asarray(s.t) for _, _, s, _, _ in plans])
    if not truth.covers(t_all).any():
        lo, hi = truth.span
        raise ScoreError(
            f"{rec.name} (estimates {_utc(t_all.min())} .. {_utc(t_all.max())}) and {truth.name} "
            f"({_utc(lo)} .. {_utc(hi)}): no overlapping time"
        )

    rows: list[Row] = []
    for name, kind, s, fields, position in plans:
        c = s.columns()
        t, vals = c.t, c.values
        start = rec.first_t[name] + warmup
        out = (t < start) | c.stale
        if position:
            lat = np.where(out, math.nan, vals["lat"])
            err, _ = position_errors(truth, t, lat, vals["lon"])
            rows.append(Row(name, kind, POSITION, "lat,lon", _POSITION_UNIT, figures(err)))
            rows.extend(_position_baselines(rec, truth, name, kind, start))
        for f in fields:
            err, idx = field_errors(truth, f.truth, t, np.where(out, math.nan, vals[f.path]), f.angle)
            sigma = vals[f.std][idx] if f.std else None
            rows.append(Row(name, kind, f.path, f.truth, f.unit, figures(err, sigma)))
            rows.extend(_baseline_rows(rec, truth, name, kind, f, start))
            rows.extend(_derived_rows(rec, truth, name, kind, f, start))
    if not any(r.figures.n for r in rows if r.baseline is None):
        raise ScoreError(
            f"{rec.name}: nothing left to score after the {warmup:g} s warm-up "
            "(stale estimates, null values and times outside the truth are left out too)"
        )
    return Score(rows, notes)
