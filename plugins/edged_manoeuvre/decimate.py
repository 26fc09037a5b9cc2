"""Sensors much faster than the ship moves, averaged to `max_rate` before the filter.

A 50 Hz IMU samples a hull whose motion has well under 1 Hz of bandwidth: five
samples averaged are one measurement with a fifth of the variance and the same
information about u̇, v̇ and r, for a fifth of the filter's work (the default filter
then stays well under 1 % of a core live, `tests/bench/bench_manoeuvre.py`). A source
is averaged only when its own interval (a running median-like estimate) is shorter
than 2/3 of the block: a 10 Hz GNSS or gyro goes to the filter sample by sample, with
no added delay. A block closes with the sample that fills it; its measurement is the
value of the straight line fitted through its readings at that last sample's time
(`_close` says why not the mean at the mean time; a compass: its circular mean at the
mean time).

A block also says how noisy its readings are: the scatter of its values about their
straight-line fit in time (a ramp is the ship, not noise), times g, is the variance of
the line's value when the readings are independent. That is known after the first block,
where learning it from the innovations takes minutes (the filter cannot tell at first
whether an innovation is sensor noise or motion). Readings that repeat exactly (a
gateway's bursts, a sensor polled faster than it measures) are not independent: such
a block gives no scatter.
"""

from __future__ import annotations

import math

import numpy as np

from .model import wrap_2pi


class _Source:
    __slots__ = ("last_t", "interval", "ts", "zs")

    def __init__(self) -> None:
        self.last_t: float | None = None
        self.interval: float | None = None
        self.ts: list[float] = []
        self.zs: list[np.ndarray] = []


class Decimator:
    def __init__(self, max_rate: float) -> None:
        self.period = 1.0 / max_rate if max_rate > 0 else 0.0
        self._src: dict[tuple[str, str], _Source] = {}

    def push(self, kind: str, source: str, t: float, z: np.ndarray,
             angle_rows: tuple[int, ...] = ()) -> tuple[float, np.ndarray, float, np.ndarray | None] | None:
        """(t, z, samples, scatter) to update with now, or None while a block fills;
        `samples` is how many single readings the block's value is worth (1/g below),
        scatter the per-row variance of that value from the block's own readings
        (None for a single reading, angles, or repeated readings)."""
        if self.period <= 0.0:
            return t, z, 1.0, None
        s = self._src.get((kind, source))
        if s is None:
            s = self._src[(kind, source)] = _Source()
        if s.last_t is not None:
            dt = t - s.last_t
            if 0.0 < dt < 10.0:
                s.interval = dt if s.interval is None else 0.9 * s.interval + 0.1 * dt
            elif dt < 0.0 or dt >= 10.0:  # out of order or a gap: start afresh
                s.ts.clear()
                s.zs.clear()
        s.last_t = t
        if s.interval is None or s.interval > self.period * (2.0 / 3.0):
            s.ts.clear()
            s.zs.clear()
            return t, z, 1.0, None
        s.ts.append(t)
        s.zs.append(np.asarray(z, dtype=float))
        if t - s.ts[0] < self.period - 0.5 * s.interval:
            return None
        out = self._close(s.ts, s.zs, angle_rows)
        s.ts, s.zs = [], []
        return out

    @staticmethod
    def _close(ts: list[float], zs: list[np.ndarray], angle_rows: tuple[int, ...]
               ) -> tuple[float, np.ndarray, float, np.ndarray | None]:
        """The block's least-squares line z = a + b·(t − t̄), valued at its last reading.

        At the block's mean time the mean would be worth n readings, but the block closes
        with its last reading, after the filter has taken the other sensors' readings up
        to then: a 50 Hz IMU's mean of yaw rate stamped 0.05 s in the past, applied to a
        filter already there, was 0.45 °/s off for a yacht's wave yaw (10 °/s²) and the
        gate threw out a third of the IMU's blocks. Valued at the last reading the line
        is in time and worth 1/g readings, g = 1/n + (t_last − t̄)²/Σ(t − t̄)² (about 2 of
        5 or 6 evenly spaced ones)."""
        n = len(ts)
        t = np.array(ts)
        Z = np.array(zs)
        zm = Z.mean(axis=0)
        tm = float(t.mean())
        if angle_rows:
            # A compass faster than 10 Hz: its circular mean at the mean time (a heading
            # moves with r, which the filter carries across the few hundredths of a
            # second; a line through a gateway's bursts of readings 2 ms apart is not).
            for i in angle_rows:
                zm[i] = wrap_2pi(math.atan2(float(np.sin(Z[:, i]).sum()), float(np.cos(Z[:, i]).sum())))
            return tm, zm, float(n), None
        dtt = t - tm
        stt = float(dtt @ dtt)
        lead = ts[-1] - tm
        g = 1.0 / n + (lead * lead / stt if stt > 0.0 else 1.0)
        if n < 3 or g >= 1.0:  # the line says no more than the last reading
            return ts[-1], zs[-1].copy(), 1.0, None
        D = Z - zm
        slope = (dtt @ D) / stt
        value = zm + slope * lead
        scatter = None
        repeats = any(np.array_equal(zs[k], zs[k - 1]) for k in range(1, n))
        if n >= 4 and not repeats:
            res = D - np.outer(dtt, slope)
            scatter = (res * res).sum(axis=0) / (n - 2) * g
        return ts[-1], value, 1.0 / g, scatter
