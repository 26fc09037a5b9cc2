"""The time series `edged plot` draws, gathered from a recording in one pass.

Kept apart from the drawing so that it is testable without matplotlib and so that the
choice of what is shown (topics and fields) is one table, not code spread over panels.
The recording is read through `edged.recordings` (whatever plugin reads its format);
the speed-through-water series and their error against truth are `stwdata`'s.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from edged.flatten import flatten
from edged.recordings import RecordedMessage, RecordingReport, recording_reader
from edged.registry import Registry
from edged.units import KNOT

from edged.geo import north_east
from .stwdata import StwRows, StwSeries
from .values import finite

__all__ = ["MARK_ORDER", "PlotData", "Series", "collect", "local_xy"]


@dataclass
class Series:
    t: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)

    def add(self, t: float, y: Any, scale: float = 1.0) -> None:
        v = finite(y)
        if v is not None and math.isfinite(v * scale):
            self.t.append(t)
            self.y.append(v * scale)


@dataclass
class PlotData:
    """Series keyed by (panel, label); tracks are (lat, lon) pairs keyed by label;
    `stw`: the stw estimate instances keyed by name (`stw`, `stw_paper`)."""

    series: dict[str, dict[str, Series]] = field(default_factory=lambda: defaultdict(dict))
    tracks: dict[str, tuple[list[float], list[float]]] = field(default_factory=dict)
    stw: dict[str, StwSeries] = field(default_factory=dict)
    t0: float | None = None
    report: RecordingReport = field(default_factory=RecordingReport)

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
_KN = 1.0 / KNOT
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
#: The draft marks in the order the "marks out" panel draws them, bottom to top.
MARK_ORDER = ("aft_stbd", "aft_port", "mid_stbd", "mid_port", "fore_stbd", "fore_port")


def _wanted(topic: str) -> bool:
    """Whether a topic has anything to draw (the others are not even decoded)."""
    family, _ = _family(topic)
    return family in _PLOTTED or family in ("meas/position", _RAW_DRAFT) or family.startswith("est/")


def _take(data: PlotData, family: str, src: str, t: float, flat: dict[str, Any]) -> None:
    for panel, fld, label, scale in _PLOTTED.get(family, ()):
        if "*" in fld:
            head, tail = fld.split("*", 1)
            for k, v in flat.items():
                if k.startswith(head) and k.endswith(tail) and finite(v) is not None:
                    mark = k[len(head) : len(k) - len(tail)]
                    data.series[panel].setdefault(label.format(mark=mark, src=src), Series()).add(t, v, scale)
            continue
        v = flat.get(fld)
        if finite(v) is not None:
            data.series[panel].setdefault(label.format(src=src), Series()).add(t, v, scale)


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
    lat, lon = finite(payload.get("lat")), finite(payload.get("lon"))
    if lat is not None and lon is not None and abs(lat) <= 90.0 and abs(lon) <= 180.0:
        lats, lons = data.tracks.setdefault(label, ([], []))
        lats.append(lat)
        lons.append(lon)


def _stw_name(topic: str, schema: str | None, payload: dict[str, Any]) -> str | None:
    """The instance name when `topic` carries an stw estimate: its `kind` says so, or
    (a recording from before kinds, or a kind left null) its schema `edged.est.stw`
    or the topic `/est/stw`."""
    if not topic.startswith("/est/") or len(topic) <= 5:
        return None
    name = topic[5:]
    kind = payload.get("kind")
    if kind == "stw":
        return name
    if kind is None and (schema == "edged.est.stw" or name == "stw"):
        return name
    return None


class _Gatherer:
    """What `collect` keeps while it reads: the plot data, the raw drafts (drawn only
    without a draft estimate) and the stw instances."""

    def __init__(self) -> None:
        self.data = PlotData()
        self.raw_drafts: dict[str, Series] = {}
        self.stw_rows: dict[str, StwRows] = {}

    def add(self, m: RecordedMessage) -> None:
        payload = m.payload
        if not isinstance(payload, dict):
            return
        data = self.data
        family, src = _family(m.topic)
        t = m.log_time / 1e9
        if data.t0 is None or t < data.t0:
            data.t0 = t
        if family.startswith("est/"):
            name = _stw_name(m.topic, m.schema, payload)
            if name is not None:
                # The estimate's own time, as `edged score` judges it (the log time
                # is the same instant, rounded to nanoseconds).
                te = finite(payload.get("t"))
                self.stw_rows.setdefault(name, StwRows()).add(t if te is None else te, payload)
            if family not in _PLOTTED:
                return
        if family == "meas/position":
            _track(data, src, payload)
        elif family == "est/manoeuvre":
            _track(data, "estimate", payload)
        if family == "est/draft":
            _marks_out(data, t, payload.get("marks"))
        if family == _RAW_DRAFT:
            self.raw_drafts.setdefault(str(payload.get("mark", src)), Series()).add(t, payload.get("draft"))
        else:
            _take(data, family, src, t, flatten(payload))

    def done(self) -> PlotData:
        data = self.data
        if not data.panel("draft"):
            data.series["draft"].update(self.raw_drafts)
        data.stw = {name: rows.series(name) for name, rows in sorted(self.stw_rows.items())}
        return data


def collect(path: Path, registry: Registry | None = None) -> PlotData:
    """What `edged plot` draws of the recording at `path`. `RecordingError` for a file
    that is no recording, OSError for one not readable."""
    g = _Gatherer()
    for m in recording_reader(path, registry or Registry()).messages(path, g.data.report, _wanted):
        g.add(m)
    return g.done()


def local_xy(lats: list[float], lons: list[float], lat0: float, lon0: float) -> tuple[list[float], list[float]]:
    """East and north metres around (lat0, lon0) (`flatearth`): exact enough over a voyage leg."""
    north, east = north_east(np.asarray(lats, dtype=float), np.asarray(lons, dtype=float), lat0, lon0)
    return east.tolist(), north.tolist()
