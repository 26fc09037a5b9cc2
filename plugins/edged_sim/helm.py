"""Orders to the rudder and the engine: scheduled manoeuvres and zigzag tests.

A manoeuvre is data: a sequence of steps, each fired by a trigger (a time, or the
heading passing a value in either direction, as the officer of the watch would do it).
A helm is the stateful thing that plays a sequence back against the simulated heading;
the integrator asks it for the orders once per step and holds them over the step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from edged.units import KNOT

from .ship import ShipParticulars, steady_thrust_speed


def _heading_diff(a: float, b: float) -> float:
    """a − b onto (−π, π].

    A copy of `edged.angles.wrap_pi` kept on purpose: this form (`fmod` after adding
    8π) rounds differently in the last bit on three values in four, and the autopilot's
    rudder is computed from it, so `wrap_pi` here changes the files of every autopilot
    scenario (measured on `yacht-seaway`: truth.csv and can.log differ). The simulated
    files stay bit for bit what they were (issue 33)."""
    return math.pi - math.fmod(math.pi - (a - b) + 8.0 * math.pi, 2.0 * math.pi)


@dataclass(frozen=True)
class Step:
    """One order. `at_s` or `heading_deg` fires it (the first that is set)."""

    at_s: float | None = None
    heading_deg: float | None = None
    rudder_deg: float | None = None  #: + starboard; None keeps the current order
    speed_kn: float | None = None  #: speed through water ordered; None keeps it
    ramp_s: float = 0.0  #: seconds to go from the present speed order to the new one


class Helm(Protocol):
    def orders(self, t: float, psi: float) -> tuple[float, float]:
        """(rudder command rad, thrust speed m/s) at time t with heading psi."""
        ...


class _SpeedRamp:
    """Speed reference moving linearly to a new value, fed forward to the surge model."""

    def __init__(self, speed: float, ship: ShipParticulars) -> None:
        self.ship = ship
        self.start_t, self.start_v, self.end_t, self.end_v = 0.0, speed, 0.0, speed

    def set(self, t: float, speed: float, ramp_s: float) -> None:
        self.start_v = self.reference(t)[0]
        self.start_t, self.end_t, self.end_v = t, t + max(ramp_s, 0.0), speed

    def reference(self, t: float) -> tuple[float, float]:
        if t >= self.end_t or self.end_t <= self.start_t:
            return self.end_v, 0.0
        slope = (self.end_v - self.start_v) / (self.end_t - self.start_t)
        return self.start_v + slope * (t - self.start_t), slope

    def thrust(self, t: float) -> float:
        return steady_thrust_speed(*self.reference(t), self.ship)


@dataclass(frozen=True)
class Manoeuvre:
    """A sequence of orders from an initial speed (knots) and rudder (degrees)."""

    speed_kn: float
    steps: tuple[Step, ...] = ()
    rudder_deg: float = 0.0

    def make(self, ship: ShipParticulars) -> "SequenceHelm":
        return SequenceHelm(self, ship)


class SequenceHelm:
    """Plays a `Manoeuvre` back: each step waits for its trigger, in order."""

    def __init__(self, spec: Manoeuvre, ship: ShipParticulars) -> None:
        self.spec = spec
        self.next = 0
        self.rudder = math.radians(spec.rudder_deg)
        self.speed = _SpeedRamp(spec.speed_kn * KNOT, ship)
        self.prev_psi: float | None = None
        self.fired: list[tuple[int, float]] = []  #: (step index, time) for the record

    def _due(self, step: Step, t: float, psi: float) -> bool:
        if step.at_s is not None:
            return t >= step.at_s
        if step.heading_deg is None or self.prev_psi is None:
            return False
        target = math.radians(step.heading_deg)
        before, now = _heading_diff(self.prev_psi, target), _heading_diff(psi, target)
        return before * now <= 0.0 and abs(before - now) < math.pi / 2 and before != now

    def orders(self, t: float, psi: float) -> tuple[float, float]:
        steps = self.spec.steps
        while self.next < len(steps) and self._due(steps[self.next], t, psi):
            step = steps[self.next]
            if step.rudder_deg is not None:
                self.rudder = math.radians(step.rudder_deg)
            if step.speed_kn is not None:
                self.speed.set(t, step.speed_kn * KNOT, step.ramp_s)
            self.fired.append((self.next, t))
            self.next += 1
        self.prev_psi = psi
        return self.rudder, self.speed.thrust(t)


@dataclass(frozen=True)
class ZigZag:
    """The classic z-manoeuvre: rudder ± `rudder_deg` at ± `heading_deg` from a base."""

    speed_kn: float
    base_heading_deg: float
    rudder_deg: float = 20.0
    heading_deg: float = 20.0
    start_s: float = 60.0

    def make(self, ship: ShipParticulars) -> "ZigZagHelm":
        return ZigZagHelm(self, ship)


class ZigZagHelm:
    def __init__(self, spec: ZigZag, ship: ShipParticulars) -> None:
        self.spec = spec
        self.side = 1.0  # first order to starboard
        self.speed = _SpeedRamp(spec.speed_kn * KNOT, ship)
        self.fired: list[tuple[int, float]] = []

    def orders(self, t: float, psi: float) -> tuple[float, float]:
        s = self.spec
        if t < s.start_s:
            return 0.0, self.speed.thrust(t)
        dev = _heading_diff(psi, math.radians(s.base_heading_deg))
        if self.side * dev >= math.radians(s.heading_deg):
            self.side = -self.side
            self.fired.append((len(self.fired), t))
        return self.side * math.radians(s.rudder_deg), self.speed.thrust(t)


@dataclass(frozen=True)
class Leg:
    """From `at_s` on: steer `heading_deg` and/or order `speed_kn` (None keeps it)."""

    at_s: float
    heading_deg: float | None = None
    speed_kn: float | None = None
    ramp_s: float = 0.0


@dataclass(frozen=True)
class Autopilot:
    """Course and speed changes steered by a heading autopilot, as ships and yachts
    make them: a PD law on the heading error, δ = Kp·(ψ_ref − ψ) − Kd·r, within ±
    `rudder_max_deg`, with gains by pole placement on the first-order Nomoto model
    (Fossen 2011 §15.3.2): Kp = ω_n²·T/K, Kd = (2ζω_n·T − 1)/K with ω_n = `bandwidth`/T,
    K = K'·U/L and T = T'·L/U at the ordered speed. A turn so steered ends on the new
    heading without the tens of degrees of overshoot an open-loop rudder order leaves
    on a sluggish hull. The autopilot reads the manoeuvring heading (a real one filters
    the wave yaw out of its compass)."""

    speed_kn: float
    legs: tuple[Leg, ...] = ()
    heading_deg: float | None = None  #: the first course; None: the scenario's start heading
    rudder_max_deg: float = 15.0
    bandwidth: float = 1.0
    damping: float = 0.9

    def make(self, ship: ShipParticulars) -> "AutopilotHelm":
        return AutopilotHelm(self, ship)


class AutopilotHelm:
    def __init__(self, spec: Autopilot, ship: ShipParticulars) -> None:
        self.spec = spec
        self.ship = ship
        self.speed = _SpeedRamp(spec.speed_kn * KNOT, ship)
        self.next = 0
        self.target: float | None = None if spec.heading_deg is None else math.radians(spec.heading_deg)
        self.prev: tuple[float, float] | None = None  #: (t, psi) of the last call, for r
        self.fired: list[tuple[int, float]] = []

    def orders(self, t: float, psi: float) -> tuple[float, float]:
        s, legs = self.spec, self.spec.legs
        while self.next < len(legs) and t >= legs[self.next].at_s:
            leg = legs[self.next]
            if leg.heading_deg is not None:
                self.target = math.radians(leg.heading_deg)
            if leg.speed_kn is not None:
                self.speed.set(t, leg.speed_kn * KNOT, leg.ramp_s)
            self.fired.append((self.next, t))
            self.next += 1
        if self.target is None:
            self.target = psi
        r = 0.0
        if self.prev is not None and t > self.prev[0]:
            r = _heading_diff(psi, self.prev[1]) / (t - self.prev[0])
        self.prev = (t, psi)
        p = self.ship
        u = max(self.speed.reference(t)[0], 0.5)
        k, tn = p.nomoto_k * u / p.length, p.nomoto_t * p.length / u
        wn = s.bandwidth / tn
        kp, kd = wn * wn * tn / k, max(2.0 * s.damping * wn * tn - 1.0, 0.0) / k
        lim = math.radians(s.rudder_max_deg)
        delta = min(max(kp * _heading_diff(self.target, psi) - kd * r, -lim), lim)
        return delta, self.speed.thrust(t)
