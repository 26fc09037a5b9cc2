"""Sensors much faster than the ship moves, averaged to `max_rate` before the filter.

A 50 Hz IMU samples a hull whose motion has well under 1 Hz of bandwidth: five
samples averaged are one measurement with a fifth of the variance and the same
information about u̇, v̇ and r, for a fifth of the filter's work (the default filter
then stays well under 1 % of a core live, `tests/bench/bench_manoeuvre.py`). A source
is averaged only when its own interval (a running median-like estimate) is shorter
than 2/3 of the block: a 10 Hz GNSS or gyro goes to the filter sample by sample, with
no added delay. A block closes with the sample that fills it; its measurement is the
mean of its values (angles: the circular mean) at the mean of its times.

A block also says how noisy its readings are: the scatter of its values about their
straight-line fit in time (a ramp is the ship, not noise) divided by n is the variance
of the mean when the readings are independent. That is known after the first block,
where learning it from the innovations takes minutes (the filter cannot tell at first
whether an innovation is sensor noise or motion). Readings that repeat exactly (a
gateway's bursts, a sensor polled faster than it measures) are not independent: such
a block gives no scatter.
"""

from __future__ import annotations

import math

import numpy as np

from edged.angles import wrap_2pi


class _Source:
    __slots__ = ("last_t", "interval", "t_sum", "z_sum", "s_sum", "c_sum", "n", "t0",
                 "tt_sum", "tz_sum", "zz_sum", "last_z", "repeats")

    def __init__(self) -> None:
        self.last_t: float | None = None
        self.interval: float | None = None
        self.n = 0


class Decimator:
    def __init__(self, max_rate: float) -> None:
        self.period = 1.0 / max_rate if max_rate > 0 else 0.0
        self._src: dict[tuple[str, str], _Source] = {}

    def push(self, kind: str, source: str, t: float, z: np.ndarray,
             angle_rows: tuple[int, ...] = ()) -> tuple[float, np.ndarray, int] | None:
        """(t, z, samples, scatter) to update with now, or None while a block fills;
        scatter is the per-row variance of the mean from the block's own readings
        (None for a single reading, angles, or repeated readings).

        The sums are kept as floats, row by row (the same additions as arrays would
        make, so the same bits): a reading of one or two rows costs numpy more in calls
        than in arithmetic, and most readings only add to a block."""
        if self.period <= 0.0:
            return t, z, 1, None
        s = self._src.get((kind, source))
        if s is None:
            s = self._src[(kind, source)] = _Source()
        if s.last_t is not None:
            dt = t - s.last_t
            if 0.0 < dt < 10.0:
                s.interval = dt if s.interval is None else 0.9 * s.interval + 0.1 * dt
            elif dt < 0.0 or dt >= 10.0:  # out of order or a gap: start afresh
                s.n = 0
        s.last_t = t
        if s.interval is None or s.interval > self.period * (2.0 / 3.0):
            s.n = 0
            return t, z, 1, None
        zl = z.tolist()
        if s.n == 0:
            zero = [0.0] * len(zl)
            s.t0, s.t_sum, s.z_sum = t, 0.0, zero
            s.s_sum, s.c_sum = np.zeros_like(z), np.zeros_like(z)
            s.tt_sum, s.tz_sum, s.zz_sum = 0.0, zero, zero
            s.last_z, s.repeats = None, 0
        s.n += 1
        s.t_sum += t
        s.z_sum = [a + b for a, b in zip(s.z_sum, zl)]
        tr = t - s.t0
        s.tt_sum += tr * tr
        s.tz_sum = [a + tr * b for a, b in zip(s.tz_sum, zl)]
        s.zz_sum = [a + b * b for a, b in zip(s.zz_sum, zl)]
        if s.last_z is not None and zl == s.last_z:
            s.repeats += 1
        s.last_z = zl
        if angle_rows:
            s.s_sum = s.s_sum + np.sin(z)
            s.c_sum = s.c_sum + np.cos(z)
        if t - s.t0 < self.period - 0.5 * s.interval:
            return None
        n = s.n
        zm = np.array(s.z_sum) / n
        for i in angle_rows:
            zm[i] = wrap_2pi(math.atan2(s.s_sum[i], s.c_sum[i]))
        s.n = 0
        return s.t_sum / n, zm, n, self._scatter(s, n, zm, angle_rows)

    @staticmethod
    def _scatter(s: _Source, n: int, zm: np.ndarray, angle_rows: tuple[int, ...]) -> np.ndarray | None:
        """Σ(z − a − b·t)² / (n − 2) / n per row: the residual variance of the block's
        least-squares line, over n. None below 4 readings or with any exact repeat."""
        if n < 4 or s.repeats or angle_rows:
            return None
        tm = (s.t_sum - n * s.t0) / n  # mean of the times since t0
        stt = s.tt_sum - n * tm * tm
        stz = np.array(s.tz_sum) - n * tm * zm
        szz = np.array(s.zz_sum) - n * zm * zm
        res = szz - (stz * stz / stt if stt > 0.0 else 0.0)
        return np.maximum(res, 0.0) / ((n - 2) * n)
