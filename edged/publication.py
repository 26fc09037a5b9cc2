"""What a worker publishes of what its core returned: every estimate under the
instance's name, or, with `publish_rate`, the newest at each tick (decimation); and
the last one again, marked `stale`, while no input has come for `stale_after` seconds
of data time (`Publication`).

Results are applied in the order of the calls that made them, after the calls (a
core in a process answers a batch at a time), so that both placements publish the
same estimates at the same data times.
"""

from __future__ import annotations

from typing import Any

from .health import ComponentHealth
from .records import Estimate
from .router import Router

__all__ = ["Publication"]

Call = tuple[str, Any]


class Publication:
    """One worker's publication state: the newest input time, the estimate held for
    the next tick, the last one published, whether it is stale."""

    def __init__(self, name: str, kind: str | None, router: Router, health: ComponentHealth,
                 publish_rate: float, stale_after: float) -> None:
        self.name = name
        self.kind = kind
        self.router = router
        self.health = health
        self.decimate = publish_rate > 0
        self.stale_after = stale_after
        self._last_input_t: float | None = None
        #: Decimated, not yet published (published at the next tick, or at the end).
        self.held: Estimate | None = None
        self._last: Estimate | None = None
        self.stale = False

    def _stamp(self, e: Estimate, age: float, stale: bool) -> Estimate:
        values = dict(e.values)
        values["stale"] = stale
        values["age"] = age
        return Estimate(self.name, self.name, e.t, values, self.kind)

    def publish(self, e: Estimate, cause: int) -> None:
        self.health.count("estimates")
        self.router.publish(e, cause)

    def publish_held(self, cause: int) -> None:
        """The decimated estimate not yet published: the last word (the worker ends)."""
        if self.held is not None:
            self.publish(self.held, cause)
            self.held = None

    def apply(self, calls: list[Call], results: list[list[Any]], causes: list[int]) -> None:
        """What the core returned, in call order: published, held or marked stale."""
        steps = 0
        last_in = self._last_input_t
        for (what, arg), out, cause in zip(calls, results, causes):
            if what == "step":
                steps += 1
                if last_in is None or arg.t > last_in:
                    last_in = arg.t
                if not out and not self.stale:  # most steps: nothing to publish
                    continue
                self._last_input_t = last_in
                self._stepped(out, cause)
                continue
            self._last_input_t = last_in
            self._ticked(arg, out, cause)
            last_in = self._last_input_t
        self._last_input_t = last_in
        if steps:
            self.health.count("steps", steps)

    def _stepped(self, out: list[Estimate], cause: int) -> None:
        """A step's estimates: published, or held for the next tick."""
        if self.stale:
            self.stale = False
            self.health.set_state("running", "inputs back")
        last_in = self._last_input_t
        assert last_in is not None
        for e in out:
            e = self._stamp(e, max(0.0, e.t - last_in), False)
            self._last = e
            if self.decimate:
                self.held = e
            else:
                self.publish(e, cause)

    def _ticked(self, t: float, out: list[Estimate], cause: int) -> None:
        """A tick of the data-time grid at `t`: what the core's tick made, the estimate
        held for it, and the stale mark when inputs stopped."""
        last_in = self._last_input_t
        for e in out:
            age = 0.0 if last_in is None else max(0.0, t - last_in)
            e = self._stamp(e, age, False)
            self._last = e
            self.publish(e, cause)
        self.publish_held(cause)
        if self.stale_after > 0 and last_in is not None and t - last_in > self.stale_after:
            if not self.stale:
                self.stale = True
                self.health.set_state("stale", f"no input for {t - last_in:.1f} s of data")
                self.health.count("stale_periods")
            last = self._last
            if last is not None:
                values = dict(last.values)
                values["stale"] = True
                values["age"] = t - last_in
                self.publish(Estimate(self.name, self.name, t, values, self.kind), cause)
        self.health.info["age"] = None if last_in is None else max(0.0, t - last_in)
