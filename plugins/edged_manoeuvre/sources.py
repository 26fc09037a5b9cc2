"""One sensor heard twice is one sensor: finding duplicated sources of a kind.

Ships often hear one gyro twice (HDT on NMEA 0183 and PGN 127250 through a gateway)
and carry two GNSS receivers. Fusing two independent receivers halves the variance;
fusing one sensor's two copies doubles its weight and makes the filter overconfident
(NIS too small, gates too tight). The router's source priority handles it when the
configuration names one; without it the estimator tells them apart itself:

two sources of a kind whose readings, paired when nearly simultaneous, differ
by less than SAME × their combined σ in at least SAME_SHARE of the last PAIRS pairs are
copies of one sensor (independent sensors differ by about their combined σ: below
half of it in 38 % of pairs; copies differ by the interfaces' rounding only). The
source heard first stays; the copy is muted (counted `duplicate.<kind>`) for as long
as the first one speaks, and takes over when it has been silent for FAILOVER seconds.
"""

from __future__ import annotations

from collections import deque

import numpy as np

#: Readings of two sources are paired when at most this far apart, and at most half
#: the sensor's own interval (a copy arrives within the interfaces' latency; the
#: previous or next reading would compare two instants).
PAIR_WINDOW = 0.05
SAME = 0.5
SAME_SHARE = 0.8
PAIRS = 50
FAILOVER = 2.0


class _Pair:
    __slots__ = ("same", "duplicate")

    def __init__(self) -> None:
        self.same: deque[bool] = deque(maxlen=PAIRS)
        self.duplicate = False


class SourceCopies:
    def __init__(self) -> None:
        self._last: dict[str, dict[str, tuple[float, np.ndarray]]] = {}  # kind -> source -> (t, z)
        self._order: dict[str, list[str]] = {}  # kind -> sources in the order first heard
        self._pairs: dict[tuple[str, str, str], _Pair] = {}

    def muted(self, kind: str, source: str, t: float, z: np.ndarray, diff, sigma) -> bool:
        """Record a reading; True when it is a copy of a source heard before that is
        still speaking. `diff(a, b)` is the kind's residual (angles wrapped), `sigma(s)`
        a source's current 1-σ per row."""
        last = self._last.setdefault(kind, {})
        order = self._order.setdefault(kind, [])
        if source not in order:
            order.append(source)
        mine = order.index(source)
        prev = last.get(source)
        window = PAIR_WINDOW if prev is None or t <= prev[0] else min(PAIR_WINDOW, 0.5 * (t - prev[0]))
        muted = False
        for other in order:
            if other == source or other not in last:
                continue
            t_o, z_o = last[other]
            a, b = (other, source) if order.index(other) < mine else (source, other)
            pair = self._pairs.get((kind, a, b))
            if pair is None:
                pair = self._pairs[(kind, a, b)] = _Pair()
            if abs(t - t_o) <= window:
                combined = np.sqrt(np.square(sigma(source)) + np.square(sigma(other)))
                pair.same.append(bool(np.all(np.abs(diff(z, z_o)) < SAME * combined)))
                if len(pair.same) >= PAIRS // 2:
                    pair.duplicate = sum(pair.same) >= SAME_SHARE * len(pair.same)
            if pair.duplicate and order.index(other) < mine and t - t_o <= FAILOVER:
                muted = True
        last[source] = (t, z)
        return muted

    def duplicates(self) -> list[str]:
        """`kind: first = copy` of every pair found to be one sensor."""
        return [f"{k}: {a} = {b}" for (k, a, b), p in sorted(self._pairs.items()) if p.duplicate]
