"""The output plugin `nmea0183` (entry point group `edged.outputs`): the fused values
back to the bridge's instruments as NMEA 0183 sentences (issue 35).

An ECDIS, a radar's ARPA, an autopilot or a chart plotter takes STW, heading and
rate of turn as NMEA 0183 over a serial line or the ship's LAN; this output sends
edged's (`encode`: VHW, VBW, VDR, HDT, ROT, XDR), each sentence at its own rate of
data time, under a talker ID of its own (`ED` by default) over UDP, a TCP server or
a serial port (`edged.bytesinks`).

No loops: the talker is the output's mark (`own_marks`), and every NMEA 0183 input
refuses sentences with it (`rejected.own_output`), so a shared UDP port or a
multiplexer that echoes everything gives no measurement of edged's own estimates.
That is also why a standard instrument's talker (GP, HE, VW, II, ...) is refused as
this output's: edged would then refuse that instrument's sentences on its inputs.
"""

from __future__ import annotations

import re
from typing import Any, ClassVar

from pydantic import Field, field_validator

from edged.bridgeoutput import BridgeOutputConfig, Message, TextBridgeOutput
from edged.bytesinks import TransportSettings

from .decoder import OWN_TALKER
from .encode import SENTENCES

__all__ = ["Nmea0183Output", "Nmea0183OutputConfig", "INSTRUMENT_TALKERS"]

#: Talker IDs of the instruments edged reads (a GNSS, a gyro, a log, an echo sounder,
#: integrated instruments, an autopilot, a weather station): refused as the output's.
INSTRUMENT_TALKERS = frozenset({
    "GP", "GN", "GL", "GA", "GB", "BD", "GI", "GQ", "HE", "HC", "HN", "TI", "VW", "VD",
    "VM", "SD", "SS", "II", "IN", "AG", "AP", "WI", "YX", "EC", "RA", "CD", "DE", "LC",
})


class Nmea0183OutputConfig(BridgeOutputConfig, TransportSettings):
    #: The talker ID of every sentence sent (two letters or digits). It marks the
    #: sentences as edged's own: no input reads them back.
    talker: str = "ED"
    #: Sentences per second of data time, by type; the defaults: VHW, VBW, VDR and XDR
    #: 1, HDT and ROT 10. 0 switches a sentence off.
    rates: dict[str, float] = Field(default_factory=dict)

    @field_validator("talker")
    @classmethod
    def _talker(cls, v: str) -> str:
        if not re.fullmatch(r"[A-Z0-9]{2}", v):
            raise ValueError(f"a talker ID is two capital letters or digits, not {v!r}")
        if v in INSTRUMENT_TALKERS:
            raise ValueError(
                f"{v} is an instrument's talker ID: edged refuses its own talker on every input, "
                "so that instrument's sentences would be refused too (choose another, e.g. ED)")
        return v


#: About how long each sentence is, line end included (XDR: its three sentences), to
#: tell an operator when the configured rates do not fit a serial line.
TYPICAL_LENGTH = {"VHW": 38, "VBW": 44, "VDR": 29, "HDT": 19, "ROT": 19, "XDR": 190}

_STW, _MAN, _DRAFT = frozenset({"stw"}), frozenset({"manoeuvre"}), frozenset({"draft"})


class Nmea0183Output(TextBridgeOutput):
    """VHW, VBW, VDR, HDT, ROT and XDR sentences over UDP, a TCP server or serial."""

    Config: ClassVar[type[Nmea0183OutputConfig]] = Nmea0183OutputConfig
    description: ClassVar[str] = "the fused values as NMEA 0183 sentences (VHW, VBW, VDR, HDT, ROT, XDR)"
    #: Each sentence, the estimates whose arrival sends it and its default rate (Hz of
    #: data time). VHW and VBW go with the STW estimate (1 Hz), with the latest
    #: heading and ground speeds of the manoeuvring state beside it.
    messages: ClassVar[tuple[Message, ...]] = (
        Message("VHW", _STW, 1.0),
        Message("VBW", _STW, 1.0),
        Message("VDR", _STW, 1.0),
        Message("HDT", _MAN, 10.0),
        Message("ROT", _MAN, 10.0),
        Message("XDR", _DRAFT, 1.0),
    )

    @classmethod
    def own_marks(cls, config: Any) -> dict[str, frozenset[str]]:
        return {OWN_TALKER: frozenset({config.talker})}

    async def open(self) -> None:
        await super().open()
        overload = self.serial_overload()
        if overload:
            self.ctx.health.error(overload)

    def serial_overload(self) -> str | None:
        """What to tell the operator when the rates need more than the serial line
        carries (10 bits a character); None when they fit or there is no line."""
        cfg = self.config
        if cfg.transport != "serial":
            return None
        need = sum(self.hz[name] * TYPICAL_LENGTH[name] for name in self.hz)
        line = cfg.baudrate / 10.0
        if need <= line:
            return None
        return (f"the sentences need about {need:.0f} characters a second and the line at {cfg.baudrate} Bd "
                f"carries {line:.0f}: lower `rates` or raise `baudrate` (what does not fit is dropped)")

    def encode(self, name: str) -> bytes:
        return SENTENCES[name](self.view, self.config.talker)
