"""Units and number checks shared by the core and the plugins (one definition each).

edged is SI throughout (m, m/s, rad); a knot appears only where a sentence or a person
speaks in knots (NMEA 0183 fields, the simulator's scenarios, the dashboard)."""

from __future__ import annotations

import math
from typing import Any

__all__ = ["KNOT", "finite_numbers"]

#: Metres per second in one knot (the international nautical mile, 1852 m, an hour).
KNOT = 1852.0 / 3600.0


def finite_numbers(*xs: Any) -> bool:
    """True when every value is a real number (int or float, not bool) and finite."""
    return all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in xs)
