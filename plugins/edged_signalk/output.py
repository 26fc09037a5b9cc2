"""The output plugin `signalk` (entry point group `edged.outputs`): the fused values as
Signal K deltas, for a Signal K server and what reads it (issue 35).

A yacht's or a ship's Signal K server (signalk-server) gathers the instruments for
its apps, plotters and loggers; this output gives it edged's STW, current, heading,
rate of turn and drafts (`paths`), each message at its own rate of data time, as
deltas (`delta`) over a TCP server it connects to (its "Signal K" data connection,
type TCP), UDP datagrams to it, or a serial line (`edged.bytesinks`).

Health: `sent` (deltas), and from the link `unsent.link_down`,
`dropped.slow_client`, `errors.send`; `rejected.bad_time` (an estimate whose time
no calendar holds: not sent), `rejected.bad_mark` (a draft mark whose name is no
path segment: left out).

No loops: no edged input reads Signal K, so the output marks nothing (`own_marks`).
"""

from __future__ import annotations

from typing import ClassVar

from edged.bridgeoutput import Message, TextBridgeOutput
from edged.plugin import PluginContext

from .config import SignalKOutputConfig
from .delta import encode_delta, iso_ms
from .paths import MARK_RE, ROLE_OF, VALUES

__all__ = ["SignalKOutput"]

_STW, _MAN, _DRAFT = frozenset({"stw"}), frozenset({"manoeuvre"}), frozenset({"draft"})


class SignalKOutput(TextBridgeOutput):
    """Signal K deltas of the fused values over a TCP server, UDP or serial."""

    Config: ClassVar[type[SignalKOutputConfig]] = SignalKOutputConfig
    description: ClassVar[str] = "the fused values as Signal K deltas (STW, current, heading, drafts)"
    #: Each delta, the estimates whose arrival sends it, its default rate (Hz of data
    #: time): the heading and rate of turn oftener, for a plotter's or radar's overlay.
    messages: ClassVar[tuple[Message, ...]] = (
        Message("speed", _STW, 1.0),
        Message("current", _STW, 1.0),
        Message("heading", _MAN, 5.0),
        Message("course", _MAN, 1.0),
        Message("draft", _DRAFT, 1.0),
    )

    def __init__(self, config: SignalKOutputConfig, ctx: PluginContext) -> None:
        super().__init__(config, ctx)
        self.source = f"edged.{ctx.name}"

    def encode(self, name: str) -> bytes | None:
        view = self.view
        t = view.time_of(ROLE_OF[name])
        if t is None:
            return None
        try:
            stamp = iso_ms(t)
        except (ValueError, OverflowError, OSError):
            self.ctx.health.count("rejected.bad_time")
            return None
        if name == "draft":
            bad = sum(1 for m in view.marks() if not MARK_RE.fullmatch(m))
            if bad:
                self.ctx.health.count("rejected.bad_mark", bad)
        return encode_delta(self.config.context, self.source, stamp, VALUES[name](view))
