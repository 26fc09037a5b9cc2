"""Numbers as a watch officer reads them: knots beside m/s, degrees, metres.

The estimates are in SI units (DESIGN §2, §6); a person on the bridge thinks in knots
and degrees. These helpers turn a payload's value into text, and anything that is not
a finite number (null, absent, NaN, a bool) into `DASH`, so that the dashboard never
shows a made-up or stale number where there is none.
"""

from __future__ import annotations

import math
from typing import Any, Callable
from edged.units import KNOT

#: What a missing, null or stale value is shown as.
DASH = "—"
#: Metres per second in one knot (1852 m per hour).


def num(x: Any) -> float | None:
    """`x` as a float when it is a finite number, else None (bools are not numbers)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def knots(v: Any, signed: bool = False) -> str:
    """A speed in knots alone: `9.72 kn`."""
    x = num(v)
    if x is None:
        return DASH
    return f"{x / KNOT:+.2f} kn" if signed else f"{x / KNOT:.2f} kn"


def speed(v: Any, signed: bool = False) -> str:
    """A speed in knots and m/s: `9.72 kn  5.00 m/s`."""
    x = num(v)
    if x is None:
        return DASH
    fmt = "+.2f" if signed else ".2f"
    return f"{format(x / KNOT, fmt)} kn  {format(x, fmt)} m/s"


def heading(rad: Any) -> str:
    """A direction in [0°, 360°), three digits as on a compass: `005.3°`."""
    x = num(rad)
    if x is None:
        return DASH
    d = round(math.degrees(x) % 360.0, 1)
    return f"{0.0 if d >= 360.0 else d:05.1f}°"


def angle(rad: Any) -> str:
    """A signed angle in (−180°, 180°]: `+2.5°`."""
    x = num(rad)
    if x is None:
        return DASH
    d = (math.degrees(x) + 180.0) % 360.0 - 180.0
    return f"{180.0 if d == -180.0 else d:+.1f}°"


def turn_rate(r: Any) -> str:
    """A yaw rate in °/s and in °/min (a rate-of-turn indicator's unit)."""
    x = num(r)
    if x is None:
        return DASH
    d = math.degrees(x)
    return f"{d:+.2f}°/s  {d * 60.0:+.0f}°/min"


def metres(m: Any, signed: bool = False, digits: int = 2) -> str:
    x = num(m)
    if x is None:
        return DASH
    return f"{x:+.{digits}f} m" if signed else f"{x:.{digits}f} m"


def distance(m: Any) -> str:
    """A distance: metres below a kilometre, else km; beyond 1000 km it says so."""
    x = num(m)
    if x is None:
        return DASH
    if abs(x) < 1000.0:
        return f"{x:.0f} m"
    if abs(x) < 1e6:
        return f"{x / 1000.0:.1f} km"
    return ">1000 km"


def position(lat: Any, lon: Any) -> str:
    """`57.60076°N 011.50000°E`."""
    a, o = num(lat), num(lon)
    if a is None or o is None:
        return DASH
    return f"{abs(a):08.5f}°{'N' if a >= 0 else 'S'} {abs(o):09.5f}°{'E' if o >= 0 else 'W'}"


def pm(std: Any, fmt: Callable[[Any], str] = knots) -> str:
    """`±<σ>` in the given format, or nothing without a σ."""
    return "" if num(std) is None else f"±{fmt(std)}"


def rate(x: Any) -> str:
    """A message rate per second."""
    v = num(x)
    if v is None:
        return DASH
    return f"{v:.0f}" if v >= 9.95 else f"{v:.1f}"


def seconds(x: Any) -> str:
    v = num(x)
    if v is None:
        return DASH
    return f"{v:.1f} s" if v < 60 else f"{v / 60:.1f} min"
