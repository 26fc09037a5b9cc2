"""The heading as the STW filter uses it: latest, smoothed, and the rate of turn.

Heading − course measures the current across the ship, and each look uses the heading
twice: in the measurement (v_g·ŷ) and in its direction (ŷ). A noisy heading sample in
both is an error in the variables: the filter reads the sample's jitter, multiplied by
the speed along the ship, as information about the current *along* the ship, and drags
that current toward the ground speed (STW → 0). So the filter looks with a smoothed
heading (exponential mean of the unit vector over `tau` seconds: 0.5° of white noise at
10 Hz becomes 0.05°), and its rate of turn, without a rate sensor, from the smoothed
heading's change over at least 5 s.
"""

from __future__ import annotations

import math

from edged.angles import wrap_2pi, wrap_pi


class HeadingTrack:
    def __init__(self, tau: float) -> None:
        self.tau = tau
        self.t: float | None = None
        self.latest: float | None = None
        self._c = 0.0
        self._s = 0.0
        self._ref: tuple[float, float] | None = None  # (t, smoothed heading) for the rate
        self.rate: tuple[float, float] | None = None  # (t, rad/s)
        #: The smoothed heading as of the last sample: read for every IMU sample and
        #: GNSS velocity, changed only by `add`.
        self._mean: float | None = None

    def add(self, t: float, h: float) -> None:
        if self.t is None:
            w = 1.0
        elif t > self.t:
            w = 1.0 - math.exp(-(t - self.t) / self.tau)
        else:
            w = 0.1  # a second source at the same instant
        self._c += w * (math.cos(h) - self._c)
        self._s += w * (math.sin(h) - self._s)
        self.t = t if self.t is None else max(self.t, t)
        self.latest = h
        mean = self._mean = self._smooth()
        if mean is None:
            return
        if self._ref is None:
            self._ref = (t, mean)
        elif t - self._ref[0] >= 5.0:
            d = -wrap_pi(self._ref[1] - mean)  # in [−π, π): the same bits as the modulo it replaced
            self.rate = (t, d / (t - self._ref[0]))
            self._ref = (t, mean)

    def smoothed(self) -> float | None:
        """The direction of the mean unit vector (None before a sample, or when the
        samples cancel out)."""
        return self._mean

    def _smooth(self) -> float | None:
        if self.t is None or math.hypot(self._c, self._s) < 1e-6:
            return None
        return wrap_2pi(math.atan2(self._s, self._c))

    def fresh(self, t: float, max_age: float) -> bool:
        return self.t is not None and t - self.t <= max_age

    def settled(self, max_deg: float = 3.0) -> bool:
        """The latest sample agrees with the mean (not in or just out of a turn)."""
        m = self.smoothed()
        if m is None or self.latest is None:
            return False
        return abs(wrap_pi(m - self.latest)) <= math.radians(max_deg)
