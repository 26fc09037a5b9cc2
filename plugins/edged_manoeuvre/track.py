"""The fixes' own track over the last seconds: its velocity, its course, and which of
two disagreeing compasses it backs.

The track is the GNSS alone, independent of the filter: the dead reckoning of the
predictions (`forecast.py`) carries the last fix on at its velocity, smoother than a
receiver's SOG, which has spikes; and a compass that disagrees with another is judged
against it, not against an estimate both have fed.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from edged.angles import wrap_pi

from .config import DEG


#: The course over ground decides between two disagreeing compasses when the track
#: of the last TRACK_SPAN s is at least TRACK_SPEED m/s and one compass is closer to it
#: than the other by TRACK_MARGIN (a drift angle is a few degrees underway, not 20).
TRACK_SPAN = 10.0
TRACK_SPEED = 1.0
TRACK_MARGIN = 5.0 * DEG


class Track:
    """(t, p_n, p_e) of the fixes taken over the last TRACK_SPAN s."""

    def __init__(self) -> None:
        self.fixes: deque[tuple[float, float, float]] = deque()

    def add(self, t: float, pn: float, pe: float) -> None:
        fixes = self.fixes
        if not fixes or fixes[-1][0] < t:
            fixes.append((t, pn, pe))
        while fixes and fixes[0][0] < t - TRACK_SPAN:
            fixes.popleft()

    def shift(self, dn: float, de: float) -> None:
        """The plane's origin moved by (dn, de) m."""
        self.fixes = deque((tt, n - dn, e - de) for tt, n, e in self.fixes)

    def velocity(self) -> tuple[float, float] | None:
        """The fixes' own velocity over the last TRACK_SPAN s (first to last)."""
        tr = self.fixes
        if len(tr) < 2 or tr[-1][0] - tr[0][0] < 0.5 * TRACK_SPAN:
            return None
        (t0, n0, e0), (t1, n1, e1) = tr[0], tr[-1]
        return (n1 - n0) / (t1 - t0), (e1 - e0) / (t1 - t0)

    def course(self) -> float | None:
        """The course of the fixes of the last TRACK_SPAN s, when they make way."""
        v = self.velocity()
        if v is None or math.hypot(*v) < TRACK_SPEED:
            return None
        return math.atan2(v[1], v[0])

    def choose(self, kind: str, first: str, second: str, z1: np.ndarray, z2: np.ndarray) -> tuple[str, str]:
        """Which of two disagreeing sources to keep (`sources.SourceCopies`), and why:
        for compasses, the one nearer the course over ground when the vessel makes way;
        else the one heard first (the one the filter has followed longest)."""
        if kind == "heading":
            cog = self.course()
            if cog is not None:
                d1 = abs(float(wrap_pi(float(z1[0]) - cog)))
                d2 = abs(float(wrap_pi(float(z2[0]) - cog)))
                if abs(d1 - d2) >= TRACK_MARGIN:
                    return (first, "nearer the course over ground") if d1 < d2 else (second, "nearer the course over ground")
        return first, "heard first"
