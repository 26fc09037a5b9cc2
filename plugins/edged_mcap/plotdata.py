"""The time series `edged plot` draws, gathered from a recording in one pass.

Kept apart from the drawing so that it is testable without matplotlib and so that the
choice of what is shown (topics and fields) is one table, not code spread over panels.

The speed-through-water panels (the paper's figures) are made from `StwSeries`, one
per `/est/<name>` channel of kind `stw` (`est/stw`, `est/stw_paper`, ...), in SI (m/s;
the drawing converts): the estimate with its σ, the Doppler log, the filtered SOG and
the current along the track. Against a truth table (`read_truth`, the simulator's
`truth.csv`, format in `edged_mcap.scoring`): `stw_error` (estimate − truth, only
where the truth's time span covers the estimate) and `error_autocorrelation` at lags
0..N samples with `white_band`, the ±1.96/√n band a white error stays inside.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .flatten import flatten
from .reading import ReadReport, iter_messages
from .scoring import ScoreError, Truth, autocorrelation, field_errors, figures, load_truth

__all__ = [
    "Series",
    "PlotData",
    "StwSeries",
    "StwError",
    "STW_FIELDS",
    "collect",
    "local_xy",
    "read_truth",
    "stw_error",
    "error_autocorrelation",
    "white_band",
    "EARTH_RADIUS",
    "ACF_LAGS",
]

EARTH_RADIUS = 6_371_008.8  # m, mean radius: plenty for a local picture


def _num(v: Any) -> float | None:
    """A JSON number as a finite float; None for anything else (a bool, NaN, infinity,
    or an integer too large for a float, which a foreign or damaged file may hold)."""
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        return None
    try:
        f = float(v)
    except OverflowError:
        return None
    return f if math.isfinite(f) else None


@dataclass
class Series:
    t: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)

    def add(self, t: float, y: Any, scale: float = 1.0) -> None:
        v = _num(y)
        if v is not None and math.isfinite(v * scale):
            self.t.append(t)
            self.y.append(v * scale)


#: The fields of an `stw` estimate the STW panel draws (DESIGN §6 `est/stw`), all m/s.
STW_FIELDS: tuple[str, ...] = ("stw", "stw_std", "dvl_stw", "sog", "current_along")
#: Default number of lags of the error autocorrelation panel (samples: seconds at 1 Hz).
ACF_LAGS = 120


@dataclass(frozen=True)
class StwSeries:
    """One `stw` estimate instance (`/est/<name>`) as arrays in time order, SI units
    (m/s); NaN where a value is null or absent. `stale`: the estimate's `stale` flag."""

    name: str
    t: np.ndarray
    stale: np.ndarray
    values: dict[str, np.ndarray]

    @property
    def stw(self) -> np.ndarray:
        return self.values["stw"]

    @property
    def stw_std(self) -> np.ndarray:
        return self.values["stw_std"]

    def has(self, key: str) -> bool:
        """Whether the field has at least one value."""
        return bool(np.isfinite(self.values[key]).any())


class _StwRows:
    """What `collect` gathers of one stw instance before it becomes a StwSeries."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.stale: list[bool] = []
        self.values: dict[str, list[float]] = {k: [] for k in STW_FIELDS}

    def add(self, t: float, payload: dict[str, Any]) -> None:
        self.t.append(t)
        self.stale.append(payload.get("stale") is True)
        for k in STW_FIELDS:
            v = _num(payload.get(k))
            self.values[k].append(math.nan if v is None else v)

    def series(self, name: str) -> StwSeries:
        t = np.asarray(self.t, dtype=float)
        order = np.argsort(t, kind="stable")
        vals = {k: np.asarray(v, dtype=float)[order] for k, v in self.values.items()}
        return StwSeries(name, t[order], np.asarray(self.stale, dtype=bool)[order], vals)


@dataclass
class PlotData:
    """Series keyed by (panel, label); tracks are (lat, lon) pairs keyed by label;
    `stw`: the stw estimate instances keyed by name (`stw`, `stw_paper`)."""

    series: dict[str, dict[str, Series]] = field(default_factory=lambda: defaultdict(dict))
    tracks: dict[str, tuple[list[float], list[float]]] = field(default_factory=dict)
    stw: dict[str, StwSeries] = field(default_factory=dict)
    t0: float | None = None
    report: ReadReport = field(default_factory=ReadReport)

    def panel(self, name: str) -> dict[str, Series]:
        return {k: s for k, s in self.series.get(name, {}).items() if s.t}


def _family(topic: str) -> tuple[str, str]:
    """`/meas/position/gnss1` -> ("meas/position", "gnss1"); `/est/stw` -> ("est/stw", "")."""
    parts = topic.strip("/").split("/", 2)
    if len(parts) == 3:
        return f"{parts[0]}/{parts[1]}", parts[2]
    return "/".join(parts), ""


#: topic family -> [(panel, field (flattened), label, scale)]; `*` in a field matches a
#: draft mark name. Scales turn SI into what a bridge officer reads (knots, deg/s).
_KN = 3600.0 / 1852.0
_DEG = 180.0 / math.pi
_PLOTTED: dict[str, list[tuple[str, str, str, float]]] = {
    "est/stw": [
        ("speed", "stw", "STW (estimate)", _KN),
        ("speed", "dvl_stw", "DVL", _KN),
        ("speed", "sog", "SOG (estimate)", _KN),
    ],
    "meas/water_speed": [("speed", "stw_long", "log {src}", _KN)],
    "meas/velocity_ground": [("speed", "sog", "SOG {src}", _KN)],
    "est/manoeuvre": [
        ("motion", "u", "u (surge)", _KN),
        ("motion", "v", "v (sway)", _KN),
        ("rate", "r", "r (yaw rate)", _DEG),
        ("rate", "drift_angle", "drift angle", _DEG),
    ],
    "est/draft": [
        ("draft", "mean_draft", "mean draft", 1.0),
        ("draft", "marks.*.mean", "{mark}", 1.0),
        ("trim", "trim", "trim (+ by the stern)", 1.0),
        ("trim", "list", "list (port - stbd)", 1.0),
    ],
}
#: Raw draft marks, used only when no draft estimate was recorded.
_RAW_DRAFT = "meas/draft"


def _take(data: PlotData, family: str, src: str, t: float, flat: dict[str, Any]) -> None:
    for panel, fld, label, scale in _PLOTTED.get(family, ()):
        if "*" in fld:
            head, tail = fld.split("*", 1)
            for k, v in flat.items():
                if k.startswith(head) and k.endswith(tail) and _num(v) is not None:
                    mark = k[len(head) : len(k) - len(tail)]
                    data.series[panel].setdefault(label.format(mark=mark, src=src), Series()).add(t, v, scale)
            continue
        v = flat.get(fld)
        if _num(v) is not None:
            data.series[panel].setdefault(label.format(src=src), Series()).add(t, v, scale)


#: The draft marks in the order the "marks out" panel draws them, bottom to top.
MARK_ORDER = ("aft_stbd", "aft_port", "mid_stbd", "mid_port", "fore_stbd", "fore_port")


def _marks_out(data: PlotData, t: float, marks: Any) -> None:
    """Each mark an estimate flags `ok: false`, at its row (1..6, `MARK_ORDER`): the
    "marks out" panel."""
    if not isinstance(marks, dict):
        return
    for i, name in enumerate(MARK_ORDER):
        m = marks.get(name)
        if isinstance(m, dict) and m.get("ok") is False:
            data.series["marks_out"].setdefault(name, Series()).add(t, i + 1)


def _track(data: PlotData, label: str, payload: dict[str, Any]) -> None:
    lat, lon = _num(payload.get("lat")), _num(payload.get("lon"))
    if lat is not None and lon is not None and abs(lat) <= 90.0 and abs(lon) <= 180.0:
        lats, lons = data.tracks.setdefault(label, ([], []))
        lats.append(lat)
        lons.append(lon)


def _stw_name(topic: str, schema: Any, payload: dict[str, Any]) -> str | None:
    """The instance name when `topic` carries an stw estimate: its `kind` says so, or
    (a recording from before kinds, or a kind left null) its schema `edged.est.stw`
    or the topic `/est/stw`."""
    if not topic.startswith("/est/") or len(topic) <= 5:
        return None
    name = topic[5:]
    kind = payload.get("kind")
    if kind == "stw":
        return name
    if kind is None and (getattr(schema, "name", None) == "edged.est.stw" or name == "stw"):
        return name
    return None


def collect(path: Path) -> PlotData:
    data = PlotData()
    raw_drafts: dict[str, Series] = {}
    stw_rows: dict[str, _StwRows] = {}
    with open(path, "rb") as f:
        for ch, schema, msg in iter_messages(f, data.report):
            family, src = _family(ch.topic)
            is_est = family.startswith("est/")
            if family not in _PLOTTED and family not in ("meas/position", _RAW_DRAFT) and not is_est:
                continue
            try:
                payload = json.loads(msg.data)
            except (ValueError, RecursionError):  # not JSON, or nested beyond any payload's depth
                continue
            if not isinstance(payload, dict):
                continue
            t = msg.log_time / 1e9
            if data.t0 is None or t < data.t0:
                data.t0 = t
            if is_est:
                name = _stw_name(ch.topic, schema, payload)
                if name is not None:
                    # The estimate's own time, as `edged score` judges it (the log time
                    # is the same instant, rounded to nanoseconds).
                    te = _num(payload.get("t"))
                    stw_rows.setdefault(name, _StwRows()).add(t if te is None else te, payload)
                if family not in _PLOTTED:
                    continue
            if family == "meas/position":
                _track(data, src, payload)
            elif family == "est/manoeuvre":
                _track(data, "estimate", payload)
            if family == "est/draft":
                _marks_out(data, t, payload.get("marks"))
            if family == _RAW_DRAFT:
                raw_drafts.setdefault(str(payload.get("mark", src)), Series()).add(t, payload.get("draft"))
            else:
                _take(data, family, src, t, flatten(payload))
    if not data.panel("draft"):
        data.series["draft"].update(raw_drafts)
    data.stw = {name: rows.series(name) for name, rows in sorted(stw_rows.items())}
    return data


# -- against truth ----------------------------------------------------------------------
def read_truth(path: Path, column: str = "stw") -> Truth:
    """The truth table at `path` (format in `edged_mcap.scoring`), which must have `t`
    and `column`. Raises ScoreError with a message naming the file: missing, not
    readable, not a truth table, or without that column."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            truth = load_truth(f, str(path))
    except FileNotFoundError:
        raise ScoreError(f"{path}: no such file") from None
    except OSError as exc:
        raise ScoreError(f"{exc.filename or path}: {exc.strerror or exc}") from None
    if column not in truth.columns:
        shown = ", ".join(list(truth.columns)[:8]) + (", ..." if len(truth.columns) > 8 else "")
        raise ScoreError(f"{path}: no '{column}' column (m/s) in the header: {shown}")
    return truth


@dataclass(frozen=True)
class StwError:
    """`stw − truth.stw` (m/s) of one instance at the samples that can be judged: those
    with an estimate, inside the truth's time span, where the truth is known. `std`:
    the estimate's own 1-σ at those samples (NaN where it published none)."""

    name: str
    t: np.ndarray
    err: np.ndarray
    std: np.ndarray

    @property
    def n(self) -> int:
        return int(self.err.size)

    def within(self) -> tuple[float | None, ...]:
        """% of errors inside ±1/2/3σ (scoring.SIGMAS), of the samples with a σ."""
        return figures(self.err, self.std).within

    @property
    def rmse(self) -> float | None:
        return figures(self.err).rmse


def stw_error(s: StwSeries, truth: Truth) -> StwError:
    """The estimate's error against truth, the way `edged score` takes it (truth
    interpolated linearly to each estimate's time, nothing extrapolated)."""
    err, idx = field_errors(truth, "stw", s.t, s.stw)
    return StwError(s.name, s.t[idx], err, s.stw_std[idx])


def error_autocorrelation(err: np.ndarray, max_lag: int = ACF_LAGS) -> np.ndarray:
    """The sample autocorrelation r_k of `err` (time order) for k = 0..max_lag, as
    `scoring.autocorrelation` defines it (biased estimator, r_0 = 1); lags the series
    is too short for are left out (the result is shorter). Empty for a series that
    does not vary: a constant error has no correlation to show."""
    x = np.asarray(err, dtype=float)
    if x.size < 2 or autocorrelation(x, 1) is None:
        return np.empty(0)
    top = min(max_lag, x.size - 1)
    out = [1.0]
    for k in range(1, top + 1):
        r = autocorrelation(x, k)
        out.append(math.nan if r is None else r)
    return np.asarray(out, dtype=float)


def white_band(n: int) -> float:
    """±1.96/√n: where about 95 % of a white series' autocorrelations lie (lag ≥ 1)."""
    return 1.96 / math.sqrt(n) if n > 0 else math.inf


def local_xy(lats: list[float], lons: list[float], lat0: float, lon0: float) -> tuple[list[float], list[float]]:
    """Equirectangular east/north metres around (lat0, lon0): exact enough over a voyage leg."""
    k = math.radians(1.0) * EARTH_RADIUS
    c = math.cos(math.radians(lat0))
    xs = [(((lo - lon0 + 180.0) % 360.0) - 180.0) * k * c for lo in lons]
    ys = [(la - lat0) * k for la in lats]
    return xs, ys
