"""Sensors much faster than the ship moves, averaged to `max_rate` before the filter.

A 50 Hz IMU samples a hull whose motion has well under 1 Hz of bandwidth: five
samples averaged are one measurement with a fifth of the variance and the same
information about u̇, v̇ and r, for a fifth of the filter's work (the default filter
then stays well under 1 % of a core live, `tests/bench/bench_manoeuvre.py`). A source
is averaged only when its own interval (a running median-like estimate) is shorter
than 2/3 of the block: a 10 Hz GNSS or gyro goes to the filter sample by sample, with
no added delay. A block closes with the sample that fills it; its measurement is the
mean of its values (angles: the circular mean) at the mean of its times.
"""

from __future__ import annotations

import math

import numpy as np

from .model import wrap_2pi


class _Source:
    __slots__ = ("last_t", "interval", "t_sum", "z_sum", "s_sum", "c_sum", "n", "t0")

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
        """(t, z, samples) to update with now, or None while a block fills."""
        if self.period <= 0.0:
            return t, z, 1
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
            return t, z, 1
        if s.n == 0:
            s.t0, s.t_sum, s.z_sum = t, 0.0, np.zeros_like(z)
            s.s_sum, s.c_sum = np.zeros_like(z), np.zeros_like(z)
        s.n += 1
        s.t_sum += t
        s.z_sum = s.z_sum + z
        if angle_rows:
            s.s_sum = s.s_sum + np.sin(z)
            s.c_sum = s.c_sum + np.cos(z)
        if t - s.t0 < self.period - 0.5 * s.interval:
            return None
        n = s.n
        zm = s.z_sum / n
        for i in angle_rows:
            zm[i] = wrap_2pi(math.atan2(s.s_sum[i], s.c_sum[i]))
        s.n = 0
        return s.t_sum / n, zm, n
