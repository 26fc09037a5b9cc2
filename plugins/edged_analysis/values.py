"""JSON payload values as numbers, one rule for `score` and `plot`: a value is a
number when it is an int or a float (not a boolean) that a float holds and is finite.
A foreign or damaged file may hold anything else: null, text, NaN, an integer of 400
digits; none of it is a number, and none of it raises."""

from __future__ import annotations

import math
from typing import Any

__all__ = ["finite", "number", "value_at"]


def finite(v: Any) -> float | None:
    """A JSON value as a finite float; None for anything else."""
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        return None
    try:
        f = float(v)
    except OverflowError:  # an integer beyond any float
        return None
    return f if math.isfinite(f) else None


def number(v: Any) -> float:
    """A JSON value as a float: NaN ("not known") for anything but a finite number."""
    f = finite(v)
    return math.nan if f is None else f


def value_at(payload: dict[str, Any], path: str) -> Any:
    """The value at a dotted path (`std.u`, `marks.fore_port.mean`), None if absent."""
    v: Any = payload
    for key in path.split("."):
        if not isinstance(v, dict):
            return None
        v = v.get(key)
    return v
