"""A seeded synthetic voyage as measurements, for the STW estimator's tests.

A vessel on a steady course at `speed` m/s through the water, in a constant current,
with the sensors of seed 000's Table 1; each sensor may be left out. Kept small and
explicit so that a failing test can be read against the physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterator

import numpy as np

from edged.records import Measurement

T0 = 1_732_350_000.0
M_PER_DEG_LAT = 111_132.0


@dataclass
class Voyage:
    speed: float = 10.0  # through the water, m/s, along the heading
    heading_deg: float = 45.0
    current_set_deg: float = 45.0
    current_drift: float = 1.0
    dvl_offset: float = 0.3
    duration: float = 3600.0
    seed: int = 0
    imu: bool = True
    gyro: bool = True
    forecasts: bool = True
    dvl: bool = True
    position_sigma: float = 2.5
    sog_sigma: float = 0.065
    forecast_sigma: float = 0.2
    heading_noise_deg: float = 0.11
    heading_hz: int = 1

    def ground_velocity(self) -> tuple[float, float]:
        h, c = math.radians(self.heading_deg), math.radians(self.current_set_deg)
        return (self.speed * math.cos(h) + self.current_drift * math.cos(c),
                self.speed * math.sin(h) + self.current_drift * math.sin(c))

    def measurements(self) -> Iterator[Measurement]:
        rng = np.random.default_rng(self.seed)
        v_n, v_e = self.ground_velocity()
        lat0, lon0 = 50.0, -1.0
        m_lon = M_PER_DEG_LAT * math.cos(math.radians(lat0))
        for k in range(int(self.duration)):
            t = T0 + k
            if self.forecasts and k % 1200 == 0:
                c = math.radians(self.current_set_deg)
                cn = self.current_drift * math.cos(c) + rng.normal(0, self.forecast_sigma)
                ce = self.current_drift * math.sin(c) + rng.normal(0, self.forecast_sigma)
                yield Measurement("current", "forecast", t, {"set": math.atan2(ce, cn) % (2 * math.pi),
                                                             "drift": math.hypot(cn, ce)})
            n, e = v_n * k + rng.normal(0, self.position_sigma), v_e * k + rng.normal(0, self.position_sigma)
            yield Measurement("position", "gnss", t + 0.1, {"lat": lat0 + n / M_PER_DEG_LAT, "lon": lon0 + e / m_lon})
            gn, ge = v_n + rng.normal(0, self.sog_sigma), v_e + rng.normal(0, self.sog_sigma)
            yield Measurement("velocity_ground", "gnss", t + 0.2,
                              {"sog": math.hypot(gn, ge), "cog": math.atan2(ge, gn) % (2 * math.pi)})
            if self.gyro:
                for j in range(self.heading_hz):
                    h = math.radians(self.heading_deg) + rng.normal(0, math.radians(self.heading_noise_deg))
                    yield Measurement("heading", "gyro", t + 0.3 + j * 0.5 / self.heading_hz, {"heading": h % (2 * math.pi)})
            if self.imu:
                for j in range(10):
                    yield Measurement("accel_body", "imu", t + 0.35 + 0.05 * j,
                                      {"ax": rng.normal(0, 0.05), "ay": rng.normal(0, 0.05), "az": 0.0})
            if self.dvl:
                yield Measurement("water_speed", "dvl", t + 0.9,
                                  {"stw_long": self.speed + self.dvl_offset + rng.normal(0, 0.05), "stw_trans": 0.0})


def run(core, measurements, tick_every: float = 1.0) -> list:
    """Step a core through measurements, ticking on the grid like the worker host."""
    out = []
    next_tick = None
    for m in measurements:
        if next_tick is None:
            next_tick = math.floor(m.t) + tick_every
        while next_tick <= m.t:
            out.extend(core.tick(next_tick))
            next_tick += tick_every
        core.step(m)
    return out
