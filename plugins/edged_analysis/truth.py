"""The truth table estimates are judged against (`truth.csv`), read into columns.

The format
----------
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
angle (so 359° → 1° passes through 0°, not 180°).
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, TextIO

import numpy as np

__all__ = ["ScoreError", "Truth", "load_truth", "read_truth"]


class ScoreError(ValueError):
    """Input that cannot be scored; the message names the file and says why."""


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


def _header(reader: Iterator[list[str]], name: str) -> list[str]:
    """The header row (the first that is not blank), which must name a `t` column."""
    header = next((row for row in reader if any(c.strip() for c in row)), None)
    if header is None:
        raise ScoreError(f"{name}: empty truth table (a header row with a 't' column is needed)")
    header = [h.strip() for h in header]
    header[0] = header[0].lstrip("\ufeff").strip()  # a byte-order mark (spreadsheet export)
    if "t" not in header:
        shown = ", ".join(header[:8]) + (", ..." if len(header) > 8 else "")
        raise ScoreError(f"{name}: no 't' column (UNIX seconds) in the header: {shown}")
    return header


def _rows(reader: Iterator[list[str]], width: int, ti: int) -> tuple[list[list[float]], int]:
    """The usable rows as numbers, and how many bad ones were skipped."""
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
    return good, bad


def load_truth(stream: TextIO, name: str) -> Truth:
    """Read a truth table (format in the module docstring) from a text stream.

    Raises ScoreError naming `name` when there is no `t` column or no usable row.
    """
    reader = csv.reader(stream)
    try:
        header = _header(reader, name)
        ti = header.index("t")
        good, bad = _rows(reader, len(header), ti)
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


def read_truth(path: Path, column: str = "stw") -> Truth:
    """The truth table at `path`, which must have `t` and `column`. Raises ScoreError
    with a message naming the file: missing, not readable, not a truth table, or
    without that column."""
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
