"""What an estimate is compared with beside truth: the raw sensors it replaces and
the derived baselines (DESIGN §4 `score`).

Derived baselines (`EstField.derived`, computed here by `DERIVED`) are scored like a
sensor: `naive_stw`, beside `stw`, is what a crew does without a filter or a log they
trust: at each SOG/COG measurement, SOG − drift·cos(set − COG) with the latest current
measurement at or before it (none before the first one). One row per pair of a
`/meas/velocity_ground/<source>` and a `/meas/current/<source>` topic (sources are not
mixed); a recording without either has no such row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import Callable

import numpy as np

from edged.estimates import ESTIMATE_KINDS

__all__ = ["Derived", "DERIVED", "baseline_fields", "naive_stw"]


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


@cache
def baseline_fields() -> dict[str, tuple[str, ...]]:
    """Measurement kind -> the fields some estimate is compared with, directly or
    through a derived baseline (and positions). Made on first use: the estimate kinds
    are the installed estimators' (entry points), looked up once."""
    out: dict[str, dict[str, None]] = {"position": {"lat": None, "lon": None}}
    for kind in ESTIMATE_KINDS.values():
        for f in kind.scored_fields():
            if f.baseline:
                out.setdefault(f.baseline[0], {})[f.baseline[1]] = None
            for name in f.derived:
                for mkind, mfields in DERIVED[name].inputs:
                    out.setdefault(mkind, {}).update(dict.fromkeys(mfields))
    return {k: tuple(v) for k, v in out.items()}
