"""The estimates and baseline measurements of a recording, as `edged score` judges them.

Read through `edged.recordings` (the reader of the file's format, whatever plugin
offers it): only the topics that carry something scored are decoded.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from edged.estimates import ESTIMATE_KINDS, EstimateKind
from edged.recordings import RecordingReport, recording_reader
from edged.registry import Registry

from .baselines import baseline_fields
from .columns import Series
from .values import number

__all__ = ["Recording", "estimate_paths", "has_position", "read_recording"]


def has_position(kind: EstimateKind) -> bool:
    return {"lat", "lon"} <= set(kind.field_names)


def estimate_paths(kind: EstimateKind) -> tuple[str, ...]:
    """The payload paths of a kind's scored fields, their σ and its position."""
    paths: dict[str, None] = {}
    for f in kind.scored_fields():
        paths[f.path] = None
        if f.std:
            paths[f.std] = None
    if has_position(kind):
        paths.update(dict.fromkeys(("lat", "lon")))
    return tuple(paths)


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
        return len(parts) == 4 and parts[1] == "meas" and parts[2] in baseline_fields() and bool(parts[3])

    def add(self, topic: str, payload: Any) -> None:
        if not self.wants(topic):
            return
        t = number(payload.get("t")) if isinstance(payload, dict) else math.nan
        if math.isnan(t):
            self.undecodable += 1
            return
        if topic.startswith("/est/"):
            self._add_estimate(topic[5:], t, payload)
            return
        s = self.measurements.get(topic)
        if s is None:
            s = self.measurements[topic] = Series(baseline_fields()[topic.split("/", 3)[2]])
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
            s = self.estimates[(name, spec.name)] = Series(estimate_paths(spec))
        s.add(t, payload)

    @property
    def names(self) -> list[str]:
        return sorted(self.first_t)

    def topics_of(self, kind: str) -> list[str]:
        prefix = f"/meas/{kind}/"
        return sorted(t for t in self.measurements if t.startswith(prefix))


def read_recording(path: Path, registry: Registry) -> tuple[Recording, RecordingReport]:
    """The estimates and baseline measurements of a recording, finished or not.
    `RecordingError` for a file that is no recording, OSError for one not readable."""
    rec = Recording(str(path))
    report = RecordingReport()
    for m in recording_reader(path, registry).messages(path, report, rec.wants):
        rec.add(m.topic, m.payload)
    rec.undecodable += report.undecodable
    return rec, report
