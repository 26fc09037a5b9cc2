"""The time series `edged plot` draws, gathered from a recording in one pass.

Kept apart from the drawing so that it is testable without matplotlib and so that the
choice of what is shown (topics and fields) is one table, not code spread over panels.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .flatten import flatten
from .reading import ReadReport, iter_messages

__all__ = ["Series", "PlotData", "collect", "local_xy", "EARTH_RADIUS"]

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


@dataclass
class PlotData:
    """Series keyed by (panel, label); tracks are (lat, lon) pairs keyed by label."""

    series: dict[str, dict[str, Series]] = field(default_factory=lambda: defaultdict(dict))
    tracks: dict[str, tuple[list[float], list[float]]] = field(default_factory=dict)
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


def _track(data: PlotData, label: str, payload: dict[str, Any]) -> None:
    lat, lon = _num(payload.get("lat")), _num(payload.get("lon"))
    if lat is not None and lon is not None and abs(lat) <= 90.0 and abs(lon) <= 180.0:
        lats, lons = data.tracks.setdefault(label, ([], []))
        lats.append(lat)
        lons.append(lon)


def collect(path: Path) -> PlotData:
    data = PlotData()
    raw_drafts: dict[str, Series] = {}
    with open(path, "rb") as f:
        for ch, _schema, msg in iter_messages(f, data.report):
            family, src = _family(ch.topic)
            if family not in _PLOTTED and family not in ("meas/position", _RAW_DRAFT):
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
            if family == "meas/position":
                _track(data, src, payload)
            elif family == "est/manoeuvre":
                _track(data, "estimate", payload)
            if family == _RAW_DRAFT:
                raw_drafts.setdefault(str(payload.get("mark", src)), Series()).add(t, payload.get("draft"))
            else:
                _take(data, family, src, t, flatten(payload))
    if not data.panel("draft"):
        data.series["draft"].update(raw_drafts)
    return data


def local_xy(lats: list[float], lons: list[float], lat0: float, lon0: float) -> tuple[list[float], list[float]]:
    """Equirectangular east/north metres around (lat0, lon0): exact enough over a voyage leg."""
    k = math.radians(1.0) * EARTH_RADIUS
    c = math.cos(math.radians(lat0))
    xs = [(((lo - lon0 + 180.0) % 360.0) - 180.0) * k * c for lo in lons]
    ys = [(la - lat0) * k for la in lats]
    return xs, ys
