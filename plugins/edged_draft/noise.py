"""One draft mark's sensor noise, learned from its own residuals.

The configured `sensor_sigma` is a start: a sensor's real noise (its electronics, the
water in its tube) is found by each mark's filter as it runs, so that a quiet sensor
is trusted more and a noisy one less.
"""

from __future__ import annotations

#: Below this the learned sensor σ is not believed (m): a stuck sensor is not precise.
SIGMA_FLOOR = 0.001


class MarkNoise:
    """One mark's reading variance, learned from its residuals (R·S⁻¹·y)² + R − R²/S,
    over about `samples` readings (a minute at 100 Hz)."""

    def __init__(self, sigma: float, samples: float = 6000.0) -> None:
        self.var = sigma * sigma
        self.alpha = 1.0 / samples
        self.n = 0

    def add(self, y: float, S: float) -> None:
        R = self.var
        e = R / S * y
        sample = e * e + R - R * R / S
        a = max(self.alpha, 1.0 / (self.n + 2))
        self.var = max((1.0 - a) * self.var + a * sample, SIGMA_FLOOR**2)
        self.n += 1
