"""A seeded synthetic voyage as measurements, for the STW estimator's tests.

A vessel on a steady course at `speed` m/s through the water, in a constant current,
with the sensors of seed 000's Table 1; each sensor may be left out. Kept small and
explicit so that a failing test can be read against the physics.

A varied voyage: the speed ramps to `speed2` (from `speed_at`, over `speed_ramp` s),
the heading turns by `turn_deg` (from `turn_at`, over `turn_time` s) and wanders by
`wander_deg` over `wander_period` s (a yacht steered by hand), the current turns at
`current_rotation_deg_h`. The hull moves along its heading (no leeway); the IMU reads
the along-ship acceleration and the centripetal U·ψ̇; `rot` adds a rate-of-turn sensor.
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
    speed2: float | None = None
    speed_at: float = 1800.0
    speed_ramp: float = 600.0
    turn_deg: float = 0.0
    turn_at: float = 1800.0
    turn_time: float = 60.0
    wander_deg: float = 0.0
    wander_period: float = 300.0
    current_rotation_deg_h: float = 0.0
    rot: bool = False
    gnss_period: int = 1  #: s between GNSS fixes (and SOG/COG): 30 for a large ship's
    imu_hz: int = 10

    def speed_at_t(self, k: float) -> tuple[float, float]:
        """Speed through the water (m/s) and its rate (m/s²) k s into the voyage."""
        if self.speed2 is None:
            return self.speed, 0.0
        f = (k - self.speed_at) / self.speed_ramp
        if f <= 0.0:
            return self.speed, 0.0
        if f >= 1.0:
            return self.speed2, 0.0
        return self.speed + (self.speed2 - self.speed) * f, (self.speed2 - self.speed) / self.speed_ramp

    def heading_at_t(self, k: float) -> tuple[float, float]:
        """Heading (rad) and its rate (rad/s)."""
        h, r = math.radians(self.heading_deg), 0.0
        if self.turn_deg:
            f = (k - self.turn_at) / self.turn_time
            h += math.radians(self.turn_deg) * min(max(f, 0.0), 1.0)
            r += math.radians(self.turn_deg) / self.turn_time if 0.0 < f < 1.0 else 0.0
        if self.wander_deg:
            w = 2.0 * math.pi / self.wander_period
            h += math.radians(self.wander_deg) * math.sin(w * k)
            r += math.radians(self.wander_deg) * w * math.cos(w * k)
        return h, r

    def current_at_t(self, k: float) -> tuple[float, float]:
        c = math.radians(self.current_set_deg + self.current_rotation_deg_h * k / 3600.0)
        return self.current_drift * math.cos(c), self.current_drift * math.sin(c)

    @property
    def varied(self) -> bool:
        return bool(self.speed2 is not None or self.turn_deg or self.wander_deg or self.current_rotation_deg_h)

    def truth(self, k: float) -> float:
        """True STW k s into the voyage (the hull moves along its heading)."""
        return self.speed_at_t(k)[0]

    def ground_velocity(self) -> tuple[float, float]:
        h, c = math.radians(self.heading_deg), math.radians(self.current_set_deg)
        return (self.speed * math.cos(h) + self.current_drift * math.cos(c),
                self.speed * math.sin(h) + self.current_drift * math.sin(c))

    def measurements(self) -> Iterator[Measurement]:
        rng = np.random.default_rng(self.seed)
        v_n, v_e = self.ground_velocity()
        lat0, lon0 = 50.0, -1.0
        m_lon = M_PER_DEG_LAT * math.cos(math.radians(lat0))
        pn = pe = 0.0
        for k in range(int(self.duration)):
            t = T0 + k
            if self.varied:
                u, du = self.speed_at_t(k)
                h, r = self.heading_at_t(k)
                c_n, c_e = self.current_at_t(k)
                v_n, v_e = u * math.cos(h) + c_n, u * math.sin(h) + c_e
            if self.forecasts and k % 1200 == 0:
                c_n, c_e = self.current_at_t(k)
                cn = c_n + rng.normal(0, self.forecast_sigma)
                ce = c_e + rng.normal(0, self.forecast_sigma)
                yield Measurement("current", "forecast", t, {"set": math.atan2(ce, cn) % (2 * math.pi),
                                                             "drift": math.hypot(cn, ce)})
            if self.varied:
                n, e = pn + rng.normal(0, self.position_sigma), pe + rng.normal(0, self.position_sigma)
                pn, pe = pn + v_n, pe + v_e  # 1 s on (the velocity changes slowly)
            else:
                n, e = v_n * k + rng.normal(0, self.position_sigma), v_e * k + rng.normal(0, self.position_sigma)
            gn, ge = v_n + rng.normal(0, self.sog_sigma), v_e + rng.normal(0, self.sog_sigma)
            if k % self.gnss_period == 0:
                yield Measurement("position", "gnss", t + 0.1, {"lat": lat0 + n / M_PER_DEG_LAT, "lon": lon0 + e / m_lon})
                yield Measurement("velocity_ground", "gnss", t + 0.2,
                                  {"sog": math.hypot(gn, ge), "cog": math.atan2(ge, gn) % (2 * math.pi)})
            h0, r0 = self.heading_at_t(k) if self.varied else (math.radians(self.heading_deg), 0.0)
            u0, du0 = self.speed_at_t(k) if self.varied else (self.speed, 0.0)
            if self.gyro:
                for j in range(self.heading_hz):
                    h = h0 + rng.normal(0, math.radians(self.heading_noise_deg))
                    yield Measurement("heading", "gyro", t + 0.3 + j * 0.5 / self.heading_hz, {"heading": h % (2 * math.pi)})
                if self.rot:
                    yield Measurement("yaw_rate", "gyro", t + 0.32, {"r": r0 + rng.normal(0, 0.0003)})
            if self.imu:
                for j in range(self.imu_hz):
                    yield Measurement("accel_body", "imu", t + 0.35 + 0.5 * j / self.imu_hz,
                                      {"ax": du0 + rng.normal(0, 0.05), "ay": u0 * r0 + rng.normal(0, 0.05), "az": 0.0})
            if self.dvl:
                yield Measurement("water_speed", "dvl", t + 0.9,
                                  {"stw_long": u0 + self.dvl_offset + rng.normal(0, 0.05), "stw_trans": 0.0})


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


def naive(ms: list, times) -> np.ndarray:
    """What a crew makes without a filter at each time: the latest SOG minus the latest
    forecast's current along the latest COG (`edged score`'s naive row)."""
    out, sog = [], None
    cur = None
    it = iter(sorted(ms, key=lambda m: m.t))
    pending = next(it, None)
    for t in times:
        while pending is not None and pending.t <= t:
            if pending.kind == "velocity_ground":
                sog = (pending.values["sog"], pending.values["cog"])
            elif pending.kind == "current":
                cur = (pending.values["set"], pending.values["drift"])
            pending = next(it, None)
        if sog is None or cur is None:
            out.append(math.nan)
            continue
        out.append(sog[0] - cur[1] * math.cos(cur[0] - sog[1]))
    return np.array(out)

