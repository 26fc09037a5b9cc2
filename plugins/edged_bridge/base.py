"""A bridge output: the fused values sent as messages, each at its own rate.

An output declares its `messages` (a sentence, a PGN, a delta), each made of the
estimates of some roles and sent at most `rates[name]` times per second of data
time (`edged.ratelimit`), whenever an estimate of one of its roles arrives: replay
sends exactly what live sent. The subclass says how a message is made
(`encode(name)` from `self.view`, None when there is nothing to send) and where it
goes (`deliver`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from pydantic import Field

from edged.plugin import OutputConfig, OutputPlugin, PluginContext
from edged.ratelimit import DataTimeRateLimiter
from edged.records import Estimate

from .view import ROLES, BridgeView, Roles

__all__ = ["Message", "BridgeOutputConfig", "BridgeOutput"]


@dataclass(frozen=True, slots=True)
class Message:
    """One message an output sends: its name, the roles it is made of, its default
    rate (Hz of data time; the configuration's `rates` overrides, 0 switches it off)."""

    name: str
    roles: frozenset[str]
    hz: float


class BridgeOutputConfig(OutputConfig):
    #: The estimator instances (their table names) whose estimates are sent; "" for
    #: none (the messages made only of it are then not sent).
    stw: str = "stw"
    manoeuvre: str = "manoeuvre"
    draft: str = "draft"
    #: Seconds of data time after which an estimate that was not renewed, while
    #: others were, goes out as "not available" (an estimator that stopped).
    max_age: float = Field(5.0, gt=0.0, le=3600.0)
    #: Messages per second of data time, by message name; those not named keep their
    #: default, 0 switches one off.
    rates: dict[str, float] = Field(default_factory=dict)


class BridgeOutput(OutputPlugin):
    """Sends `messages` made from the latest estimates (see the module's docstring)."""

    Config: ClassVar[type[BridgeOutputConfig]] = BridgeOutputConfig
    messages: ClassVar[tuple[Message, ...]] = ()

    def __init__(self, config: BridgeOutputConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        self.view = BridgeView(Roles(config.stw, config.manoeuvre, config.draft), config.max_age)
        #: Only the estimates of its roles are routed to it.
        self.keys = self.view.keys  # type: ignore[misc]
        self._limiter = DataTimeRateLimiter()
        self.hz = {m.name: float(config.rates.get(m.name, m.hz)) for m in self.messages}
        self._by_role: dict[str, list[Message]] = {
            role: [m for m in self.messages if role in m.roles and self.hz[m.name] > 0] for role in ROLES
        }

    def check(self) -> None:
        known = {m.name for m in self.messages}
        for name, hz in self.config.rates.items():
            if name not in known:
                raise ValueError(f"rates: unknown message {name!r} (known: {', '.join(sorted(known))})")
            if not hz >= 0 or hz > 1000:
                raise ValueError(f"rates.{name}: {hz} is not a rate between 0 and 1000 Hz")

    def encode(self, name: str) -> Any | None:
        """The message `name` made from `self.view`; None: nothing to send now."""
        raise NotImplementedError

    def deliver(self, name: str, payload: Any) -> None:
        """Send a message; never blocks, never raises (count what cannot go)."""
        raise NotImplementedError

    def write(self, batch: list[Any]) -> None:
        view, allow, hz, count = self.view, self._limiter.allow, self.hz, self.ctx.health.count
        for rec in batch:
            if not isinstance(rec, Estimate):
                continue
            role = view.update(rec)
            if role is None:
                continue
            for m in self._by_role[role]:
                if allow(m.name, rec.t, hz[m.name]):
                    payload = self.encode(m.name)
                    if payload is not None:
                        self.deliver(m.name, payload)
                        count("sent")
