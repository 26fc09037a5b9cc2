"""Seeded synthetic draft-mark streams for the draft estimator's tests: a rigid hull
(heave, pitch, roll at one encounter frequency) on a static floating position that
may change (cargo work), six marks at 100 Hz with white sensor noise, and faults."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from edged.records import Measurement

T0 = 1_700_000_000.0
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")
#: (station sign fore +1 … aft −1, side port −1 / stbd +1)
GEOMETRY = {m: ({"fore": 1.0, "mid": 0.0, "aft": -1.0}[m.split("_")[0]], -1.0 if m.endswith("port") else 1.0)
            for m in MARKS}


@dataclass
class Hull:
    duration: float = 300.0
    rate: float = 100.0
    sigma: float = 0.1
    seed: int = 1
    mean: Callable[[np.ndarray], np.ndarray] = field(default=lambda t: np.full_like(t, 10.0))
    trim: float = 0.3  # aft − fore
    list_: float = 0.05  # port − stbd
    deflection: float = 0.04
    heave: float = 0.3  # amplitudes, m at the marks
    pitch: float = 0.25  # at the fore/aft marks
    roll: float = 0.1  # at the side
    period: float = 12.0
    #: A sea travelling along the hull that the marks read at their own places: its
    #: amplitude (m) and its phase lag from one station to the next (rad: π/2, a wave of
    #: twice the fore-to-aft distance), which no rigid heave, pitch and roll can give.
    sea: float = 0.0
    sea_lag: float = math.pi / 2.0
    #: mark -> function(t, value, status) -> (value or None to drop, status)
    faults: dict[str, Callable[[float, float, int], tuple[float | None, int]]] = field(default_factory=dict)

    def mark_mean(self, m: str, t: np.ndarray) -> np.ndarray:
        x, y = GEOMETRY[m]
        base = self.mean(t) - x * self.trim / 2.0 - y * self.list_ / 2.0
        return base + (self.deflection if x == 0.0 else 0.0)

    def mark_wave(self, m: str, t: np.ndarray) -> np.ndarray:
        x, y = GEOMETRY[m]
        w = 2.0 * math.pi / self.period
        return (self.heave * np.sin(w * t) + x * self.pitch * np.sin(w * t + 1.0)
                + y * self.roll * np.sin(w * t + 2.0) + self.sea * np.sin(w * t - x * self.sea_lag + 0.3 * y))

    def times(self) -> np.ndarray:
        return np.arange(0.0, self.duration, 1.0 / self.rate)

    def measurements(self) -> Iterator[Measurement]:
        rng = np.random.default_rng(self.seed)
        t = self.times()
        z = {m: self.mark_mean(m, t) + self.mark_wave(m, t) + rng.normal(0.0, self.sigma, len(t)) for m in MARKS}
        for i, ti in enumerate(t):
            for m in MARKS:
                value, status = float(z[m][i]), 0
                f = self.faults.get(m)
                if f is not None:
                    got, status = f(float(ti), value, status)
                    if got is None:
                        continue
                    value = got
                yield Measurement("draft", "can0.DraftMark", T0 + float(ti),
                                  {"mark": m, "draft": value, "status": status})


def run(core, ms, tick: float = 1.0) -> list:
    """Feed in order, ticking on the data-time grid as the worker host does."""
    out = []
    nxt = None
    for m in ms:
        if nxt is None:
            nxt = math.floor(m.t / tick) * tick + tick
        while m.t >= nxt:
            out += core.tick(nxt)
            nxt += tick
        core.step(m)
    return out
