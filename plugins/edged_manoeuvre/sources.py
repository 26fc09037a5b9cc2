"""Several sources of one quantity: copies of one sensor, and sensors that disagree.

Ships often hear one gyro twice (HDT on NMEA 0183 and PGN 127250 through a gateway)
and carry two GNSS receivers or two compasses. Fusing two independent receivers halves
the variance; fusing one sensor's two copies doubles its weight and makes the filter
overconfident (NIS too small, gates too tight); and fusing two compasses that disagree
(a satellite compass and a deviated fluxgate, 26° apart on the SY Suster Anna) makes a
heading that no sensor gave, which jumps between the two at every update: the yaw rate
reached 762 °/s and the SOG 19 kn at a berth. The router's source priority handles it
when the configuration names one; without it the estimator tells them apart itself.

Readings of two sources of a kind are paired when nearly simultaneous; over the last
PAIRS pairs,
- **copies**: they differ by less than SAME × their combined σ in at least SAME_SHARE
  of the pairs (independent sensors differ by about their combined σ: below half of it
  in 38 % of pairs; copies differ by the interfaces' rounding only). The source heard
  first stays; the copy is muted (`duplicate.<kind>`) for as long as the first one
  speaks, and takes over when it has been silent for FAILOVER seconds.
- **disagreeing**: they differ by more than APART × their combined σ *and* by more than
  the kind's physical tolerance (`floor`: what two good sensors of that kind may differ
  by, a compass's deviation or two antennas' lever arm) in at least SAME_SHARE of the
  pairs. One of them is wrong, and their mean certainly is: the caller's `choose` says
  which one to keep (the one that agrees with the course over ground, or the one heard
  first), the other is muted (`disagree.<kind>`) while the kept one speaks. The pair is
  agreeing again when fewer than AGAIN_SHARE of its pairs are apart.
- otherwise: two independent sensors, both used; except for the kinds given as
  `one_at_a_time` (GNSS positions): two receivers on one hull see the same satellites
  through the same atmosphere, so their errors are not independent, and they differ by
  their antennas' lever arm, so fixes taken from each in turn make a track that jumps
  by metres at every fix (three receivers at the SY Suster Anna's berth, 1–7 m apart:
  the SOG reached 6 kn). The source heard first is used, the others stand by
  (`standby`) and take over when it has been silent for FAILOVER seconds.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Callable

import numpy as np

#: Readings of two sources are paired when at most this far apart, and at most half
#: the sensor's own interval (a copy arrives within the interfaces' latency; the
#: previous or next reading would compare two instants).
PAIR_WINDOW = 0.05
SAME = 0.5
SAME_SHARE = 0.8
PAIRS = 50
FAILOVER = 2.0
#: A reading is compared with at most this many other sources of its kind speaking at
#: once (a ship has two or three of each sensor; a thousand at once is a replay of a
#: thousand files of one instant, and pairs grow with the square).
MAX_COMPARED = 8
#: Two sources are apart when they differ by more than this many combined σ (and by
#: more than the kind's floor); they disagree when SAME_SHARE of their pairs are apart,
#: from half a window of pairs on, and agree again when fewer than AGAIN_SHARE are.
APART = 5.0
AGAIN_SHARE = 0.2


@dataclass
class Disagreement:
    """Two sources of a kind that disagree, and which of them is kept."""

    kind: str
    first: str
    second: str
    kept: str
    why: str
    diff: np.ndarray  # the latest pair's difference, second − first (the kind's residual)
    since: float


class _Pair:
    __slots__ = ("same", "apart", "duplicate", "disagreement")

    def __init__(self) -> None:
        self.same: deque[bool] = deque(maxlen=PAIRS)
        self.apart: deque[bool] = deque(maxlen=PAIRS)
        self.duplicate = False
        self.disagreement: Disagreement | None = None


#: choose(kind, first, second, z_first, z_second) -> (kept source, why)
Choose = Callable[[str, str, str, np.ndarray, np.ndarray], tuple[str, str]]


class SourceCopies:
    def __init__(self, floor: dict[str, np.ndarray] | None = None, choose: Choose | None = None,
                 one_at_a_time: frozenset[str] = frozenset()) -> None:
        self.one_at_a_time = one_at_a_time
        #: kind -> source -> (t, z) of the sources heard within FAILOVER s (older
        #: ones are dropped as they are met: they neither pair nor mute)
        self._last: dict[str, dict[str, tuple[float, np.ndarray]]] = {}
        self._rank: dict[str, dict[str, int]] = {}  # kind -> source -> order first heard
        self._pairs: dict[tuple[str, str, str], _Pair] = {}
        self._floor = floor or {}
        self._choose: Choose = choose or (lambda kind, a, b, za, zb: (a, "heard first"))
        #: Disagreements found since the caller last looked (`take_new`).
        self._new: list[Disagreement] = []

    def muted(self, kind: str, source: str, t: float, z: np.ndarray, diff, sigma) -> bool:
        """Record a reading; True when it is a copy of a source heard before that is
        still speaking, or the source not kept of two that disagree. `diff(a, b)` is
        the kind's residual (angles wrapped), `sigma(s)` a source's current 1-σ per row."""
        last = self._last.get(kind)
        if last is None:
            last = self._last[kind] = {}
            self._rank[kind] = {}
        rank = self._rank[kind]
        mine = rank.get(source)
        if mine is None:
            mine = rank[source] = len(rank)
        prev = last.get(source)
        if prev is not None and len(last) == 1:  # the only source heard: nothing to pair
            last[source] = (t, z)
            return False
        window = PAIR_WINDOW if prev is None or t <= prev[0] else min(PAIR_WINDOW, 0.5 * (t - prev[0]))
        floor = self._floor.get(kind)
        muted = False
        compared = 0
        for other, (t_o, z_o) in list(last.items()):
            if other == source:
                continue
            if t - t_o > FAILOVER:
                # silent for longer than a failover: nothing to pair with or defer
                # to. Dropped, so that a replay of a thousand files one after the
                # other compares each reading with the few sources speaking now
                # (it compared with every source ever heard: 1,000 files, 95 s, 1.7 GB)
                del last[other]
                continue
            compared += 1
            if compared > MAX_COMPARED:
                break
            first_is_other = rank[other] < mine
            a, b = (other, source) if first_is_other else (source, other)
            pair = self._pairs.get((kind, a, b))
            if pair is None:
                pair = self._pairs[(kind, a, b)] = _Pair()
            if abs(t - t_o) <= window:
                d = np.abs(diff(z, z_o))
                combined = np.sqrt(np.square(sigma(source)) + np.square(sigma(other)))
                pair.same.append(bool(np.all(d < SAME * combined)))
                apart = bool(np.any((d > APART * combined) & (d > floor if floor is not None else True)))
                pair.apart.append(apart)
                if len(pair.same) >= PAIRS // 2:
                    pair.duplicate = sum(pair.same) >= SAME_SHARE * len(pair.same)
                    self._judge(pair, kind, a, b, t, z if a == source else z_o, z_o if a == source else z, diff)
            if t - t_o > FAILOVER:
                continue
            if first_is_other and kind in self.one_at_a_time:
                muted = True
            if pair.duplicate and first_is_other:
                muted = True
            dis = pair.disagreement
            if dis is not None and dis.kept == other:
                muted = True
        last[source] = (t, z)
        return muted

    def _judge(self, pair: _Pair, kind: str, a: str, b: str, t: float, za: np.ndarray, zb: np.ndarray,
               diff) -> None:
        share = sum(pair.apart) / len(pair.apart)
        if pair.disagreement is None:
            if share >= SAME_SHARE:
                kept, why = self._choose(kind, a, b, za, zb)
                pair.disagreement = Disagreement(kind, a, b, kept, why, diff(zb, za), t)
                self._new.append(pair.disagreement)
        elif share < AGAIN_SHARE:
            pair.disagreement = None
        else:
            pair.disagreement.diff = diff(zb, za)

    def take_new(self) -> list[Disagreement]:
        """The disagreements found since the last call (the caller may start again
        from the kept source: its state is the two sources' mix)."""
        new = self._new
        if new:
            self._new = []
        return new

    def duplicates(self) -> list[str]:
        """`kind: first = copy` of every pair found to be one sensor."""
        return [f"{k}: {a} = {b}" for (k, a, b), p in sorted(self._pairs.items()) if p.duplicate]

    def disagreements(self) -> list[Disagreement]:
        """Every pair that disagrees now, in (kind, first, second) order."""
        return [p.disagreement for _, p in sorted(self._pairs.items()) if p.disagreement is not None]
