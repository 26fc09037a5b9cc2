"""Estimates and a plugin context for the bridge outputs' tests (issue 35)."""

from __future__ import annotations

import math
from typing import Any

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.records import Estimate

T0 = 1_764_900_000.0
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")


def stw(t: float = T0, **over: Any) -> Estimate:
    v = {"stale": False, "converging": False, "stw": 6.1732, "stw_std": 0.05, "sog": 6.5,
         "stw_long": 6.1501, "stw_trans": -0.5312, "current": 0.7717, "current_set": math.radians(123.44),
         "mode": "vector"}
    v.update(over)
    return Estimate("stw", "stw", t, v, "stw")


def manoeuvre(t: float = T0, **over: Any) -> Estimate:
    v = {"stale": False, "converging": False, "heading": math.radians(271.26), "r": math.radians(-0.4321),
         "u": 6.4112, "v": 0.2875, "sog": 6.4176, "cog": math.radians(273.83), "drift_angle": 0.0448,
         "drift_angle_water": math.radians(-2.71), "lat": 59.4371234, "lon": 24.7451234}
    v.update(over)
    return Estimate("manoeuvre", "manoeuvre", t, v, "manoeuvre")


def draft(t: float = T0, marks: dict[str, dict[str, Any]] | None = None, **over: Any) -> Estimate:
    ms = marks or {m: {"draft": 8.0 + 0.1 * i, "mean": 8.0 + 0.1 * i + 0.003, "ok": True}
                   for i, m in enumerate(MARKS)}
    v = {"stale": False, "converging": False, "marks": ms, "mean_draft": 8.253, "trim": 0.404, "list": -0.1,
         "squat": 0.12, "ukc": 4.5}
    v.update(over)
    return Estimate("draft", "draft", t, v, "draft")


class Ctx:
    """A plugin context on a manual clock; published records land in `published`."""

    def __init__(self, name: str = "out", kind: str = "bridge") -> None:
        self.clock = ManualClock(T0)
        self.health = ComponentHealth(name, "output", kind, self.clock)
        self.published: list[Any] = []
        self.ctx = PluginContext(name=name, clock=self.clock, health=self.health, publish=self.published.append)


class CaptureSink:
    """A byte sink that keeps what is sent (the transports have tests of their own)."""

    up = True  # a link that is there

    def __init__(self) -> None:
        self.sent: list[bytes] = []

    async def open(self) -> None:
        pass

    async def close(self) -> None:
        pass

    def send(self, data: bytes) -> bool:
        self.sent.append(data)
        return True

    def status(self) -> dict[str, Any]:
        return {}
