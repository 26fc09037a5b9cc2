"""A bridge output: the fused values sent as messages, each at its own rate.

The NMEA 0183, NMEA 2000 and Signal K outputs (issue 35) each send the same few
values (STW, current, heading, rate of turn, the drafts) in their own format; what
they share is in the core, once, and knows no format: `edged.bridgeview` (the
latest value of each, None where it must not go out as a number), this module (an
output of messages at their own rates) and `edged.bytesinks` (the UDP, TCP server
and serial links a text protocol goes out on).

An output declares its `messages` (a sentence, a PGN, a delta), each sent, at most
`rates[name]` times per second of data time (`edged.ratelimit`), when an estimate of
one of its roles arrives: replay sends exactly what live sent. The subclass says how
a message is made (`encode(name)` from `self.view`, None when there is nothing to
send) and where it goes (`deliver`, False when it could not go: `sent` counts what went).
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from typing import Any, ClassVar

from pydantic import Field, field_validator

from .plugin import OutputConfig, OutputPlugin, PluginContext
from .ratelimit import DataTimeRateLimiter
from .records import Estimate

from .bridgeview import ROLES, BridgeView, Roles
from .bytesinks import ByteSink, make_sink

__all__ = ["Message", "BridgeOutputConfig", "BridgeOutput", "TextBridgeOutput"]

#: Seconds between looks at the link while `ready()` waits.
READY_POLL = 0.02


@dataclass(frozen=True, slots=True)
class Message:
    """One message an output sends: its name, the roles whose estimates send it when
    they arrive (it may read others' latest values too), its default rate (Hz of data
    time; the configuration's `rates` overrides, 0 switches it off)."""

    name: str
    roles: frozenset[str]
    hz: float


class BridgeOutputConfig(OutputConfig):
    #: The STW estimator instance (its table name) whose estimates are sent; "": none.
    stw: str = "stw"
    #: The manoeuvring-state estimator instance whose estimates are sent; "": none.
    manoeuvre: str = "manoeuvre"
    #: The draft estimator instance whose estimates are sent; "": none.
    draft: str = "draft"
    #: Seconds of data time an estimator's values may be apart from the estimate
    #: being sent and still go out beside it (farther: "not available", e.g. the
    #: heading of a manoeuvre estimator that stopped, beside a new STW).
    max_age: float = Field(5.0, gt=0.0, le=3600.0)
    #: Messages per second of data time, by message name; those not named keep their
    #: default, 0 switches one off.
    rates: dict[str, float] = Field(default_factory=dict)
    #: `edged replay`: seconds to wait at the start for the link to be up (a socket
    #: open, a bus joined) before the first record; 0 does not wait.
    replay_wait: float = Field(5.0, ge=0.0, le=3600.0)

    @field_validator("worker")
    @classmethod
    def _in_the_loop(cls, v: str) -> str:
        # An output's process runs its event loop only during a call (open, write,
        # close): a link kept open in the background (a TCP server, a bus, an
        # address claim's deadlines, a heartbeat) would never come up there.
        if v != "loop":
            raise ValueError('a bridge output runs in the daemon\'s loop only (worker = "loop"): '
                             "its links are kept open by tasks that a process of its own would not run")
        return v


class BridgeOutput(OutputPlugin):
    """Sends `messages` made from the latest estimates (see the module's docstring)."""

    Config: ClassVar[type[BridgeOutputConfig]] = BridgeOutputConfig
    messages: ClassVar[tuple[Message, ...]] = ()
    #: A message combines estimators (VHW's heading beside its STW): in a replay they
    #: come in the order of the records they were made from (`OutputPlugin.ordered`).
    ordered: ClassVar[bool] = True

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

    def check_estimators(self, configured: frozenset[str]) -> None:
        """A role named in the configuration must be an estimator instance; a default
        name that is not (no draft estimator) only leaves its messages unsent."""
        for role in ROLES:
            name = getattr(self.config, role)
            if name and role in self.config.model_fields_set and name not in configured:
                known = ", ".join(sorted(configured)) or "none"
                raise ValueError(f"{role} = {name!r} names no estimator instance (configured: {known})")

    def linked(self) -> bool:
        """Whether the link is up (`ready` waits for it); the subclass says how."""
        return True

    def link_problems(self) -> list[str]:
        """What health shows while the messages cannot go (`ok: false`): the link down.
        A subclass may add its own (an NMEA 2000 address not held)."""
        if self.linked():
            return []
        return [f"not delivering: the link is {self.ctx.health.info.get('link') or 'not open'}"]

    def status(self) -> dict[str, Any]:
        """(each health snapshot) An output whose link is down is not ok, whatever
        its state: the instruments get nothing."""
        self.ctx.health.set_problems(self.link_problems())
        return {}

    async def ready(self, timeout: float | None = None) -> bool:
        """Until `linked()` (polled), at most `timeout` s of wall time (default
        `replay_wait`): a replay's first messages are not lost to a link that is
        still opening. A TCP server is up when it listens: its clients come when
        they come."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + (self.config.replay_wait if timeout is None else max(0.0, timeout))
        while not self.linked():
            if loop.time() >= deadline:
                return False
            await asyncio.sleep(READY_POLL)
        return True

    def encode(self, name: str) -> Any | None:
        """The message `name` made from `self.view`; None: nothing to send now."""
        raise NotImplementedError

    def deliver(self, name: str, payload: Any) -> bool:
        """Send a message; never blocks, never raises. False: it could not go (the
        reason counted by the link), and it is not counted `sent`."""
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
                    if payload is not None and self.deliver(m.name, payload):
                        count("sent")


class TextBridgeOutput(BridgeOutput):
    """A bridge output whose messages are bytes on a `edged.bytesinks` link (NMEA 0183
    sentences, Signal K deltas); its configuration is also a `TransportSettings`."""

    def __init__(self, config: BridgeOutputConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        #: Made at open (a plugin in a process of its own is pickled before); a test
        #: may put its own here first.
        self.sink: ByteSink | None = None

    async def open(self) -> None:
        if self.sink is None:
            self.sink = make_sink(self.config, self.ctx.health)  # type: ignore[arg-type]
        await self.sink.open()

    async def close(self) -> None:
        if self.sink is not None:
            await self.sink.close()

    def linked(self) -> bool:
        return self.sink is not None and self.sink.up

    def deliver(self, name: str, payload: Any) -> bool:
        if self.sink is None:  # written before open: not in the runtime
            self.ctx.health.count("unsent.link_down")
            return False
        return self.sink.send(payload)

    def status(self) -> dict[str, Any]:
        super().status()
        return self.sink.status() if self.sink is not None else {}
