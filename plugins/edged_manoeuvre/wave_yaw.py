"""The yaw rate split into the turn that moves the track and the wave's yaw about it.

r low-passed over R_LF_TAU s is the turn: the predictions hold it (`forecast.py`),
not the instant r of a hull swinging in a seaway. The variance of r about it over
R_WAVE_TAU s is the wave's yaw: what an accelerometer read one sample at a time cannot
follow (`update.UpdateSteps._slow_accel_R`).
"""

from __future__ import annotations

import math

#: The time constant (s) of the yaw rate's low pass: the turn that moves the track.
R_LF_TAU = 20.0
#: The time constant (s) of the variance of r about its low-passed value: the wave's yaw.
R_WAVE_TAU = 10.0


class WaveYaw:
    """r low-passed (`r_lf`, None before the first update) and the variance of r about
    it (`var`, rad²/s²)."""

    def __init__(self) -> None:
        self.r_lf: float | None = None
        self._t: float | None = None
        self.var = 0.0

    def add(self, t: float, r: float) -> None:
        """r_lf += (1 − e^(−Δt/τ))·(r − r_lf) at each applied update, and the variance
        likewise over R_WAVE_TAU."""
        if self.r_lf is None or self._t is None:
            self.r_lf, self._t = r, t
            return
        dt = t - self._t
        if dt > 0.0:
            self.r_lf += (1.0 - math.exp(-dt / R_LF_TAU)) * (r - self.r_lf)
            self.var += (1.0 - math.exp(-dt / R_WAVE_TAU)) * ((r - self.r_lf) ** 2 - self.var)
            self._t = t

    def forget(self) -> None:
        self.r_lf = self._t = None
        self.var = 0.0
