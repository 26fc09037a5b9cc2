"""A seeded synthetic manoeuvre with exact kinematic truth, for the manoeuvre estimator's tests.

The vessel moves as the CTRA model says (constant body-axis accelerations between
orders, constant yaw rate between orders), integrated finely here in closed steps, and
is measured by: GNSS positions (10 Hz), a gyro heading (10 Hz), a rate gyro (50 Hz),
accelerometers (50 Hz, with a bias). `orders` change r (and a_u, a_v) at given times:
a sudden rudder order. `rotate` turns the whole voyage about the plane's origin by
that angle (positions, heading, course): the same noise draws, so two runs differ only
by the rotation (a run through north against the same run through south).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from edged.geo import LocalPlane
from edged.records import Measurement

T0 = 1_732_350_000.0
LAT0, LON0 = 57.6, 11.5


@dataclass
class Manoeuvre:
    duration: float = 300.0
    u: float = 6.0
    v: float = 0.2
    heading_deg: float = 340.0
    r_deg: float = 0.0
    #: (time from start s, r deg/s, a_u, a_v) orders
    orders: tuple[tuple[float, float, float, float], ...] = ()
    rotate_deg: float = 0.0
    seed: int = 0
    position_sigma: float = 1.5
    heading_sigma_deg: float = 0.1
    rate_sigma_deg: float = 0.01
    accel_sigma: float = 0.02
    accel_bias: tuple[float, float] = (0.005, -0.003)
    gnss_hz: float = 10.0
    heading_hz: float = 10.0
    imu_hz: float = 50.0
    #: The hull's wave yaw over the steered heading: (amplitude °, period s); ψ gains
    #: A sin(2πt/T) and r its derivative (a yacht in a seaway: ±5° at 3–6 s).
    wave_yaw: tuple[float, float] = (0.0, 10.0)
    #: The wave's yaw turns the hull about a steady track (a yacht's: the velocity over
    #: ground does not swing with the bow), not the track with it: the body velocities
    #: then swing, and the accelerometers read their rates.
    steady_course: bool = False
    truth: list[tuple[float, float, float, float, float, float, float, float, float]] = field(default_factory=list)

    def measurements(self) -> Iterator[Measurement]:
        """Measurements in time order; `self.truth` fills with (t, n, e, u, v, ψ, r, a_u, a_v)."""
        rng = np.random.default_rng(self.seed)
        plane = LocalPlane(LAT0, LON0)
        rot = math.radians(self.rotate_deg)
        cr, sr = math.cos(rot), math.sin(rot)
        dt = 1.0 / math.lcm(int(self.gnss_hz), int(self.heading_hz), int(self.imu_hz))
        n = e = 0.0
        u, v = self.u, self.v
        psi = math.radians(self.heading_deg)
        r = math.radians(self.r_deg)
        au = av = 0.0
        orders = sorted(self.orders)
        steps = int(round(self.duration / dt))
        every = {k: int(round(1.0 / (hz * dt))) for k, hz in
                 (("gnss", self.gnss_hz), ("heading", self.heading_hz), ("imu", self.imu_hz))}
        self.truth.clear()
        for k in range(steps + 1):
            t_rel = k * dt
            while orders and orders[0][0] <= t_rel + 1e-9:
                _, r_deg, au, av = orders.pop(0)
                r = math.radians(r_deg)
            t = T0 + t_rel
            # the hull: the steered heading plus the wave's yaw
            w_amp, w = math.radians(self.wave_yaw[0]), 2.0 * math.pi / self.wave_yaw[1]
            wy, wr = w_amp * math.sin(w * t_rel), w_amp * w * math.cos(w * t_rel)
            psi_h, r_h = psi + wy, r + wr
            ub, vb, aub, avb = u, v, au, av  # the body axes' velocities and their rates
            if self.steady_course:  # the track's velocity seen from the yawing hull
                c, s_ = math.cos(wy), math.sin(wy)
                ub, vb = c * u + s_ * v, -s_ * u + c * v
                aub = c * au + s_ * av + wr * vb
                avb = -s_ * au + c * av - wr * ub
            # the rotated world: positions and angles turned by `rotate`
            nr, er = cr * n - sr * e, sr * n + cr * e
            psr = (psi_h + rot) % (2 * math.pi)
            self.truth.append((t, nr, er, ub, vb, psr, r_h, aub, avb))
            if k % every["gnss"] == 0:
                dn, de = rng.normal(0, self.position_sigma, 2)  # turned with the world too
                lat, lon = plane.to_geodetic(nr + cr * dn - sr * de, er + sr * dn + cr * de)
                yield Measurement("position", "gnss", t, {"lat": lat, "lon": lon, "fix_quality": 1})
            if k % every["heading"] == 0:
                h = (psr + math.radians(rng.normal(0, self.heading_sigma_deg))) % (2 * math.pi)
                yield Measurement("heading", "gyro", t, {"heading": h})
            if k % every["imu"] == 0:
                yield Measurement("yaw_rate", "imu", t, {"r": r_h + math.radians(rng.normal(0, self.rate_sigma_deg))})
                ax = aub - vb * r_h + self.accel_bias[0] + rng.normal(0, self.accel_sigma)
                ay = avb + ub * r_h + self.accel_bias[1] + rng.normal(0, self.accel_sigma)
                yield Measurement("accel_body", "imu", t, {"ax": ax, "ay": ay, "az": 0.0})
            # exact CTRA step: body velocities change linearly, the heading turns
            c0, s0 = math.cos(psi_h), math.sin(psi_h)
            psi1 = psi + r * dt
            psi1_h = psi1 + w_amp * math.sin(w * (t_rel + dt))
            if self.steady_course:  # the track turns with the steered heading only
                c0, s0 = math.cos(psi), math.sin(psi)
                psi1_h = psi1
            c1, s1 = math.cos(psi1_h), math.sin(psi1_h)
            u1, v1 = u + au * dt, v + av * dt
            n += 0.5 * dt * ((u * c0 - v * s0) + (u1 * c1 - v1 * s1))
            e += 0.5 * dt * ((u * s0 + v * c0) + (u1 * s1 + v1 * c1))
            u, v, psi = u1, v1, psi1


def run(core, measurements, rate: float = 10.0, bound: int | None = None,
        problems: dict[float, list[str] | None] | None = None) -> list:
    """Feed a core as the worker host does: ticks on the data-time grid k/rate; with
    `bound`, at most that many ticks at once (the host skips the rest of a longer
    gap); `problems` maps tick times to fill with health's problems just after them."""
    out = []
    nxt = None
    for m in measurements:
        if nxt is None or (bound is not None and (m.t - nxt) * rate > bound):
            nxt = math.floor(m.t * rate) / rate + 1.0 / rate
        while m.t >= nxt - 1e-9:
            out.extend(core.tick(nxt))
            if problems is not None:
                for at in problems:
                    if abs(nxt - at) < 1e-6:
                        problems[at] = core.health()["problems"]
            nxt = round(nxt + 1.0 / rate, 6)
        core.step(m)
    return out


def truth_at(truth: list, t: float) -> tuple:
    """The truth row at or just before t."""
    lo, hi = 0, len(truth) - 1
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if truth[mid][0] <= t + 1e-9:
            lo = mid
        else:
            hi = mid - 1
    return truth[lo]
