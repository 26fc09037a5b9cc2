"""The speed through the water as the draft filter uses it: the squat's driver.

The STW estimate (`est/<stw_from>`) arrives about once a second; the marks' filters
step at their sensors' rate and need the speed squared, and its rate, at each step.
"""

from __future__ import annotations

from collections import deque

import numpy as np


class SpeedFit:
    """The latest STW estimate, its σ, and a least-squares line through the last
    `window` seconds of them, carried forward between estimates."""

    def __init__(self, window: float, max_age: float) -> None:
        self.window = window
        self.max_age = max_age
        self.latest: tuple[float, float] | None = None  # t, m/s
        self.std: float | None = None
        self._recent: deque[tuple[float, float]] = deque()  # (t, m/s) over `window`
        self._fit = (0.0, 0.0, 0.0)  # t, fitted STW there (m/s), its rate (m/s²)

    def add(self, t: float, v: float, std: float | None) -> None:
        """One STW estimate (m/s) and its 1-σ (None: not given).

        Why a line, not the latest estimate as it is: its second-to-second scatter
        (about 1 cm/s) is, in V², as large as a fast squat ramp's own change; a filter
        fed noisy increments takes them for too weak a squat (regression dilution) and
        lets the level's rate carry the ramp instead. A line follows a ramp without lag."""
        self.latest = (t, v)
        self.std = std
        recent = self._recent
        if recent and t < recent[-1][0] - 1e-9:
            return
        recent.append((t, v))
        while recent and recent[0][0] < t - self.window:
            recent.popleft()
        if len(recent) < 3:
            self._fit = (t, v, 0.0)
            return
        ts = np.array([r[0] for r in recent]) - t
        vs = np.array([r[1] for r in recent])
        rate, at_t = np.polyfit(ts, vs, 1)
        self._fit = (t, float(at_t), float(rate))

    def fresh(self, t: float) -> bool:
        """An estimate younger than `max_age` s at t."""
        return self.latest is not None and t - self.latest[0] <= self.max_age

    def squared(self, t: float) -> tuple[float | None, float]:
        """STW squared at t (m²/s², None: none fresh) and its rate: the fitted line
        carried forward, for at most two seconds."""
        if self.latest is None or t - self.latest[0] > self.max_age:
            return None, 0.0
        t0, v0, rate = self._fit
        v = max(v0 + rate * min(max(t - t0, 0.0), 2.0), 0.0)
        return v * v, 2.0 * v * rate
