"""The estimator core's contract: one base class, one dispatch, one health shape.

An estimator core is synchronous: the worker host (`edged.workers`) feeds it its
inputs in data-time order, one record at a time, and it never reads a clock, so that
the same log gives the same estimates live, in a replay, at any speed. It subclasses
`Estimator` and declares:

- a handler per measurement kind it consumes, `@handles("depth")`; estimates of other
  estimator instances go to the handler of `ESTIMATES`, and `upstream(config)` names
  those instances (the draft core reads `est/<stw_from>`). A handler returns the
  estimates this record makes, or None; only their `t` and `values` matter (the host
  sets their name, source and kind, and adds `stale` and `age`);
- `tick(t)`, when it computes its output at the ticks of the data-time grid
  k/publish_rate rather than per record (a 600 Hz draft filter published at 1 Hz);
- `details()` and `problems()`, its own part of the health report.

Why a table of handlers rather than `getattr(self, "_on_" + kind)` or an if/elif
chain per core: `step` runs per measurement (tens of thousands a second), so its
dispatch is one dict lookup, built once per class and bound once per core, and the
kinds a core consumes are read from its class and configuration without making one
(the worker subscribes before any core exists, and a process worker makes its core in
another process).

Every core's health has the same keys (`health()`): `innovation` (NIS per
innovation kind, `edged.innovation`), `resets`, `last_reset`, `last_reset_t`, `seen`
(records received per input, every input listed), `rejected` (`<kind>.<reason>` ->
count; a gate rejection is `<kind>.gate`, the same count as `innovation.<kind>.gated`)
and `problems` (what makes the worker not ok), then the core's own keys.
"""

from __future__ import annotations

from collections import Counter
from typing import Any, Callable, ClassVar, TypeVar

from .innovation import InnovationMonitor
from .records import Estimate, Measurement

__all__ = ["ESTIMATES", "Estimator", "handles", "HEALTH_KEYS"]

#: The handler key of estimates from the instances `upstream` names (`est/<name>`).
ESTIMATES = "est/*"
#: Keys every core's `health()` has; `details()` adds others, never one of these.
HEALTH_KEYS = frozenset({"innovation", "resets", "last_reset", "last_reset_t", "seen", "rejected", "problems"})

F = TypeVar("F", bound=Callable[..., Any])


def handles(*keys: str) -> Callable[[F], F]:
    """Declare a method the handler of records of these measurement kinds (or of
    `ESTIMATES`): `handler(self, record) -> list[Estimate] | None`."""

    def mark(fn: F) -> F:
        fn.__edged_handles__ = getattr(fn, "__edged_handles__", ()) + keys  # type: ignore[attr-defined]
        return fn

    return mark


class Estimator:
    """Base of every estimator core (see the module's docstring).

    A subclass's `__init__` calls `super().__init__(config)` first: it binds the
    handlers and makes `seen`, `rejected` and `monitor`, which the handlers count in.
    """

    #: Whether the core has its own `tick` (set per class: the worker host fires ticks
    #: for it even without a publish_rate or stale_after).
    ticks: ClassVar[bool] = False
    #: Updates per innovation kind the NIS statistics are taken over.
    nis_window: ClassVar[int] = 100
    #: handler key (measurement kind or ESTIMATES) -> method name, per class.
    _handlers: ClassVar[dict[str, str]] = {}

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        table: dict[str, str] = {}
        for klass in reversed(cls.__mro__):
            for attr, fn in vars(klass).items():
                for key in getattr(fn, "__edged_handles__", ()):
                    table[key] = attr
        cls._handlers = table
        cls.ticks = cls.tick is not Estimator.tick

    # -- what it consumes: from the class and the configuration alone -----------------
    @classmethod
    def upstream(cls, config: Any) -> tuple[str, ...]:
        """Names of the estimator instances whose estimates this core reads (none)."""
        return ()

    @classmethod
    def consumes(cls, config: Any) -> frozenset[str]:
        """The route keys it takes: its handlers' measurement kinds and `est/<name>`
        of each upstream instance."""
        names = tuple(cls.upstream(config))
        if names and ESTIMATES not in cls._handlers:
            raise TypeError(f"{cls.__name__} reads estimates of {names} but has no @handles(ESTIMATES)")
        kinds = {k for k in cls._handlers if k != ESTIMATES}
        return frozenset(kinds | {f"est/{n}" for n in names})

    def __init__(self, config: Any) -> None:
        self.cfg = config
        #: Route keys it consumes (the worker host subscribes to these).
        self.inputs: frozenset[str] = self.consumes(config)
        names = type(self)._handlers
        self._dispatch: dict[str, Callable[[Any], list[Estimate] | None]] = {
            key: getattr(self, names[ESTIMATES if key.startswith("est/") else key]) for key in self.inputs
        }
        #: Records received per input (route key).
        self.seen: dict[str, int] = dict.fromkeys(sorted(self.inputs), 0)
        #: Records not used, by `<kind>.<reason>`.
        self.rejected: Counter[str] = Counter()
        self.monitor = InnovationMonitor(window=self.nis_window)

    # -- the calls the worker host makes ------------------------------------------------
    def step(self, rec: Measurement | Estimate) -> list[Estimate]:
        """One input record, through its handler; the estimates it makes now."""
        key = rec.route_key
        handle = self._dispatch.get(key)
        if handle is None:
            return []
        self.seen[key] += 1
        return handle(rec) or []

    def tick(self, t: float) -> list[Estimate]:
        """The estimates at the grid time t (none: a core that publishes per record)."""
        return []

    def health(self) -> dict[str, Any]:
        """The filter's health for the worker's `info.filter`: the shared keys
        (`HEALTH_KEYS`), then the core's own (`details`)."""
        out = self.monitor.snapshot()
        out["seen"] = dict(self.seen)
        out["rejected"] = dict(sorted(self.rejected.items()))
        out["problems"] = self.problems()
        own = self.details()
        clash = HEALTH_KEYS & own.keys()
        if clash:
            raise ValueError(f"{type(self).__name__}.details() redefines {sorted(clash)}")
        out.update(own)
        return out

    # -- what a core adds -----------------------------------------------------------------
    def details(self) -> dict[str, Any]:
        """The core's own health keys (its mode, per-sensor state): none here."""
        return {}

    def problems(self) -> list[str]:
        """What makes the worker not `ok` while it lasts (none here)."""
        return []

    # -- counting, the same way in every core -------------------------------------------
    def updated(self, kind: str, nis: float, dof: int) -> None:
        """An update of `kind` the gate let in, with its NIS and measurement size."""
        self.monitor.update(kind, nis, dof)

    def gated(self, kind: str) -> None:
        """A measurement of `kind` the innovation gate kept out."""
        self.monitor.gated(kind)
        self.rejected[kind + ".gate"] += 1

    def reset(self, reason: str, t: float | None = None) -> None:
        """The filter (or part of it) started again, and why."""
        self.monitor.reset(reason, t)
