"""The values derived from the six marks' wave-free drafts (seed 003 §2–§3). Pure
functions of the marks' means: what a chief officer or a pilot reads.

Marks are `<station>_<side>`: stations fore, mid, aft; sides port, stbd (DESIGN §5).
"""

from __future__ import annotations

import math

import numpy as np
from edged.units import KNOT

STATIONS = ("fore", "mid", "aft")
SIDES = ("port", "stbd")
MARKS = tuple(f"{st}_{sd}" for st in STATIONS for sd in SIDES)


def partner(mark: str) -> str:
    st, sd = mark.split("_")
    return f"{st}_{'stbd' if sd == 'port' else 'port'}"


def station_lists(means: dict[str, float | None]) -> dict[str, float]:
    """port − starboard at each station where both marks are good."""
    out = {}
    for st in STATIONS:
        p, s = means.get(f"{st}_port"), means.get(f"{st}_stbd")
        if p is not None and s is not None:
            out[st] = p - s
    return out


def fill(mark: str, means: dict[str, float | None]) -> float | None:
    """A missing mark from its partner and the list seen at the other stations
    (ESTIMATORS.md §3): a rigid hull lists alike along its length. None when its
    partner is missing too, or no other station shows the list."""
    other = means.get(partner(mark))
    st, sd = mark.split("_")
    lists = [v for s, v in station_lists(means).items() if s != st]
    if other is None or not lists:
        return None
    lst = sum(lists) / len(lists)
    return other + lst if sd == "port" else other - lst


def stations(means: dict[str, float | None]) -> dict[str, float | None]:
    """Each station's mean of port and starboard."""
    out: dict[str, float | None] = {}
    for st in STATIONS:
        p, s = means.get(f"{st}_port"), means.get(f"{st}_stbd")
        out[st] = None if p is None or s is None else 0.5 * (p + s)
    return out


def floating_position(means: dict[str, float | None], beam: float | None) -> dict[str, float | None]:
    """Mean draft, trim (aft − fore, + by the stern), list (port − starboard), heel,
    deflection (mid − mean(fore, aft), + sagging), from the six means (filled)."""
    st = stations(means)
    fore, mid, aft = st["fore"], st["mid"], st["aft"]
    vals = [v for v in means.values() if v is not None]
    known = [v for v in st.values() if v is not None]
    if len(vals) == len(MARKS):
        mean = sum(vals) / len(vals)
    else:  # a mark that could not be filled: the stations that are whole
        mean = sum(known) / len(known) if known else None
    lists = list(station_lists(means).values())
    lst = sum(lists) / len(lists) if lists else None
    return {
        "mean_draft": mean,
        "trim": aft - fore if fore is not None and aft is not None else None,
        "list": lst,
        "heel": math.atan2(lst, beam) if lst is not None and beam else None,
        "deflection": mid - 0.5 * (fore + aft) if None not in (fore, mid, aft) else None,  # type: ignore[operator]
    }


#: The rigid hull's wave motion at each mark: heave, pitch (fore +1, mid 0, aft −1: the
#: mid marks half-way) and roll (port −1, starboard +1), up to scale.
RIGID = {m: (1.0, {"fore": 1.0, "mid": 0.0, "aft": -1.0}[m.split("_")[0]], -1.0 if m.endswith("port") else 1.0)
         for m in MARKS}


def rigid_waves(waves: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]] | None:
    """The marks' wave parts (value, error variance) as a rigid hull moves them.

    A hull heaves, pitches and rolls as one body: six marks carry three motions, so
    each mark's own estimate of its wave part, independent of the others' errors, is
    improved by the weighted least-squares fit of the three (error variance about
    halved with six marks). None with fewer than four marks."""
    names = [m for m in MARKS if m in waves]
    if len(names) < 4:
        return None
    A = np.array([RIGID[m] for m in names])
    w = np.array([1.0 / max(waves[m][1], 1e-12) for m in names])
    z = np.array([waves[m][0] for m in names])
    Aw = A * w[:, None]
    N = A.T @ Aw
    if np.linalg.cond(N) > 1e8:
        return None
    Ni = np.linalg.inv(N)
    beta = Ni @ (Aw.T @ z)
    fit = A @ beta
    var = np.einsum("ij,jk,ik->i", A, Ni, A)
    return {m: (float(fit[i]), float(var[i])) for i, m in enumerate(names)}


def draft_at(x: float, fore: float, aft: float, spacing: float) -> float:
    """The draft x m ahead of midships on the straight line through the fore and aft
    marks (spacing m apart, midships half-way)."""
    return 0.5 * (fore + aft) + (fore - aft) * x / spacing


def barrass_squat(stw: float, cb: float, blockage: float | None) -> float:
    """Maximum squat, m (Barrass): S_max = K·C_b·V²/100, V in knots, K = 5.74·S^0.76 with
    S the blockage; open water (or S below 0.1, the formula's open-water end): K = 1."""
    s = 0.1 if blockage is None else max(blockage, 0.1)
    k = 5.74 * s**0.76
    v = stw / KNOT
    return k * cb * v * v / 100.0


def water_depth(depth_below_transducer: float, draft_at_transducer: float, transducer_height: float) -> float:
    """The sounder's reading plus how deep it sits (the draft there less its height
    above the keel): the water under the ship, from her keel line's datum."""
    return depth_below_transducer + (draft_at_transducer - transducer_height)


def displacement(mean_draft: float, tpc: float | None, table: list[tuple[float, float]] | None,
                 reference: float) -> tuple[float, float] | None:
    """(displacement change since the reference mean draft, t; tonnes per metre at the
    present draft): from the hydrostatic table (interpolated) when given, else TPC
    (ΔΔ ≈ 100·TPC·Δ(mean draft)). None without either."""
    if table:
        return _table(table, mean_draft) - _table(table, reference), _slope(table, mean_draft)
    if tpc:
        return 100.0 * tpc * (mean_draft - reference), 100.0 * tpc
    return None


def _table(table: list[tuple[float, float]], d: float) -> float:
    if d <= table[0][0]:
        (d0, w0), (d1, w1) = table[0], table[1]
    elif d >= table[-1][0]:
        (d0, w0), (d1, w1) = table[-2], table[-1]
    else:
        i = next(i for i in range(1, len(table)) if table[i][0] >= d)
        (d0, w0), (d1, w1) = table[i - 1], table[i]
    return w0 + (w1 - w0) * (d - d0) / (d1 - d0)


def _slope(table: list[tuple[float, float]], d: float) -> float:
    i = next((i for i in range(1, len(table)) if table[i][0] >= d), len(table) - 1)
    (d0, w0), (d1, w1) = table[i - 1], table[i]
    return (w1 - w0) / (d1 - d0)
