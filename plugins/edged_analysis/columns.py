"""A channel's messages as columns of numbers: what `edged score` judges.

JSON payloads come in one at a time; the figures want arrays in time order. A value
that is not a number (`values.number`) is NaN: "not known" is one thing to every
figure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .values import number, value_at

__all__ = ["Columns", "Series"]


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
            self.values.setdefault(p, []).append(number(value_at(payload, p)))

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
