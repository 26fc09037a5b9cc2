"""NMEA 2000 gateway log formats: one module per format, one framer path to the decoder.

Each module has:
- `NAME`: the format's name, carried in each raw record's meta (`{"format": NAME}`);
(`NAME` is also the module's name: the decoder finds a record's framer by it.)
- `sniff(head: bytes) -> bool`: whether a file's first bytes are this format;
- `read(stream, source, health, options) -> Iterator[RawRecord]`: the file's records,
  each holding the gateway's own bytes (a line), its time, and the meta above; times
  and dates are the reader's business (a time of day needs a date), bad lines are
  counted under `rejected.<reason>`;
- `frame(data: bytes) -> list[Frame | Message]`: what one record carries, for the CAN
  decoder (`decoder.CanDecoder`), which treats a `Frame` like a frame read from a bus
  and a `Message` (a fast-packet PGN the gateway already reassembled) like the output
  of our fast-packet assembler; raises `Bad(reason, message)` for what cannot be read.

So a recording of raw records replays through the very decoder that read it live, and
every format gives the same measurements, sources and counters as a CAN bus.
(`textlog` is no format: the reading loop the text formats' `read` share.)
"""

from __future__ import annotations

import importlib
import re
from dataclasses import dataclass
from types import ModuleType
from typing import Any, Callable


@dataclass(frozen=True, slots=True)
class Frame:
    """One CAN frame: a 29-bit identifier and up to 8 data bytes."""

    can_id: int
    data: bytes
    #: A frame the gateway itself sent onto the bus (YDWG `T`): decoded alike, and
    #: counted `frames.tx` by the decoder, live and in replay.
    tx: bool = False


@dataclass(frozen=True, slots=True)
class Message:
    """One whole NMEA 2000 message (a gateway reassembled its fast-packet frames)."""

    prio: int
    pgn: int
    src: int
    dst: int
    payload: bytes


class Bad(ValueError):
    """A record that cannot be read; `reason` names its counter (`rejected.<reason>`)."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


#: `Bad` reasons that are no error: the gateway's own traffic, counted under these
#: names (not `rejected.*`) and not decoded.
NOT_REJECTED = {
    "gateway_message": "gateway_messages",  # its answers and reports (BST A0, Actisense plain)
    "gateway_tx": "gateway_tx",  # what was sent to it or by it (BST A1/94, $MXPGN)
    "gateway_status": "gateway_status",  # iKonvert `$PDGY` status sentences
}


def can_id(prio: int, pgn: int, src: int, dst: int) -> int:
    """The 29-bit identifier of (priority, PGN, source, destination): ISO 11783-3.

    PDU1 (PF < 240) carries the destination in the PS byte; PDU2 PGNs include PS.
    """
    pf = (pgn >> 8) & 0xFF
    if pf < 240:
        pgn = (pgn & 0x3FF00) | (dst & 0xFF)
    return ((prio & 0x7) << 26) | ((pgn & 0x3FFFF) << 8) | (src & 0xFF)


def rejecter(health: Any, prefix: str = "") -> Callable[[str, str], None]:
    """`reject(reason, message)` for a reader: counts `rejected.<reason>` every time and
    logs the first message of each reason (a million bad lines: one warning each)."""
    reported: set[str] = set()

    def reject(reason: str, message: str) -> None:
        health.count("rejected." + reason)
        if reason not in reported:
            reported.add(reason)
            health.error(f"{prefix}{message} (further such lines counted as rejected.{reason})")

    return reject


DAY_MS = 86_400_000


def n2k_utc_ms(days: int, secs_e4: int, earliest: float, latest: float) -> int | None:
    """UTC (ms since 1970) of an NMEA 2000 date (days since 1970) and time of day
    (0.0001 s), as PGNs 126992 and 129029 carry them; None when "not available", an
    error code, beyond a leap second, or outside the plausible window [earliest, latest]
    (UNIX s). The gateway formats that lack a date take theirs from this."""
    if days >= 0xFFFD or secs_e4 >= 864_010_000:
        return None
    ms = days * DAY_MS + secs_e4 // 10
    return ms if earliest * 1000.0 <= ms <= latest * 1000.0 else None


def check_sum(body: bytes, given: bytes) -> None:
    """An NMEA 0183 checksum (XOR of the bytes between `$` and `*`), or `Bad("checksum")`."""
    x = 0
    for b in body:
        x ^= b
    if x != int(given, 16):
        raise Bad("checksum", f"checksum {given.decode()} but the sentence's is {x:02X}")


# The formats a log of which `edged replay` reads are the readers of `edged_can.logs`
# (entry point group `edged.logs`), each sniffed in its priority's order.


_BY_NAME: dict[str, ModuleType | None] = {}
_NAME = re.compile(r"[a-z][a-z0-9_]{0,31}")


def by_name(name: str) -> ModuleType | None:
    """The module of format `name` (its NAME is its module name), None if there is
    none: names come from records (an MCAP file's meta), so only plain identifiers of
    this package are looked up."""
    if name not in _BY_NAME:
        module = None
        if _NAME.fullmatch(name):
            try:
                module = importlib.import_module(f"{__name__}.{name}")
            except ModuleNotFoundError:
                module = None
        if module is not None and getattr(module, "NAME", None) != name:
            module = None
        if len(_BY_NAME) < 64:
            _BY_NAME[name] = module
        return module
    return _BY_NAME[name]
