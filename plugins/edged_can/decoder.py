"""The decoder of one CAN bus: a RawRecord alone -> measurements.

It needs nothing but the record (the identifier and the extended flag travel in
`meta`), so a frame read live, from a candump log or back from an MCAP recording is
decoded alike. Frames the DBC describes go to the DBC decoder (whatever their
identifier length); other 29-bit frames are NMEA 2000; other 11-bit frames are counted
as unknown and, like everything, were already recorded raw.

Before any of that, the length: a classic CAN frame carries at most 8 data bytes and
a CAN FD frame at most 64. A record is FD when its `meta` says so (`"fd": true`) or the
DBC defines its frame as FD; anything else is classic, and NMEA 2000 always is. A frame
longer than its kind allows is counted `rejected.bad_length` and not decoded.

No loops: the decoder is told the NAMEs of edged's own NMEA 2000 outputs (`own`, the
mark `n2k.name`). It learns from the address claims (PGN 60928) it sees which NAME
holds which address, and a frame (or a gateway's whole message) from an address whose
last claim carried one of our NAMEs, the claim included, is counted
`rejected.own_output` and gives no measurement.
"""

from __future__ import annotations

from typing import Any

from edged.health import ComponentHealth
from edged.plugin import NO_MARKS, OwnMarks
from edged.records import Measurement, RawRecord

from .config import CanConfig
from .dbc import DbcDecoder
from .emit import Emitter
from . import formats
from .n2k import N2kDecoder
from .n2k_codec import split_id
from .output.marks import OWN_GATEWAY_TX, OWN_NAME, parse_names, parse_pgns

CLASSIC_MAX = 8
FD_MAX = 64


class CanDecoder:
    def __init__(self, bus: str, config: CanConfig, health: ComponentHealth, own: OwnMarks = NO_MARKS) -> None:
        self.bus = bus
        self._health = health
        self._own = _OwnGuard(parse_names(own.get(OWN_NAME, frozenset())))
        #: PGNs edged sends through a YDWG: its `T` lines of them are edged's own.
        self._own_tx = parse_pgns(own.get(OWN_GATEWAY_TX, frozenset()))
        emit = Emitter(health)
        self._dbc = DbcDecoder(bus, config, health, emit)
        self._n2k = N2kDecoder(bus, config, health, emit)

    def decode(self, raw: RawRecord) -> list[Measurement]:
        fmt = raw.meta.get("format") if isinstance(raw.meta, dict) else None
        if fmt is not None:
            return self._decode_gateway(raw, fmt)
        count = self._health.count
        ident = _identifier(raw.meta)
        if ident is None or not isinstance(raw.data, (bytes, bytearray)):
            count("rejected.no_identifier")
            self._health.error(f"{raw.source}: CAN record without a valid meta id/ext or bytes: {raw.meta!r}")
            return []
        can_id, ext = ident
        count("frames")
        is_dbc = self._dbc.knows(can_id, ext)
        n = len(raw.data)
        if n > CLASSIC_MAX:
            # NMEA 2000 is classic CAN only; a DBC or unknown frame may be FD.
            fd = not (ext and not is_dbc) and (_says_fd(raw.meta) or self._dbc.is_fd(can_id, ext))
            if n > FD_MAX or not fd:
                count("rejected.bad_length")
                self._health.error(
                    f"{raw.source}: frame 0x{can_id:x} with {n} data bytes "
                    f"(classic CAN and NMEA 2000 carry at most {CLASSIC_MAX}, CAN FD {FD_MAX})"
                )
                return []
        if is_dbc:
            count("frames.dbc")
            return self._dbc.decode(raw, can_id, ext)
        if ext:
            if self._own.names and self._own.frame(can_id, raw.data):
                count("rejected.own_output")
                return []
            count("frames.n2k")
            return self._n2k.decode(raw, can_id)
        count(f"unknown_id.0x{can_id:03x}")
        return []


    def _decode_gateway(self, raw: RawRecord, fmt: Any) -> list[Measurement]:
        """A gateway's own record (a log line): its framer, then the path of a frame
        from a bus or of a message our fast-packet assembler made (`formats`)."""
        health = self._health
        module = formats.by_name(fmt) if isinstance(fmt, str) else None
        if module is None or not isinstance(raw.data, (bytes, bytearray)):
            health.count("rejected.unknown_format")
            health.error(f"{raw.source}: record of unknown gateway format {fmt!r}")
            return []
        try:
            items = module.frame(bytes(raw.data))
        except formats.Bad as bad:
            counter = formats.NOT_REJECTED.get(bad.reason)
            if counter is not None:
                health.count(counter)
            else:
                health.count("rejected." + bad.reason)
                health.error(f"{raw.source}: {bad}")
            return []
        out: list[Measurement] = []
        for item in items:
            if isinstance(item, formats.Frame):
                if item.tx:
                    health.count("frames.tx")
                    if self._own_tx and split_id(item.can_id)[1] in self._own_tx:
                        health.count("rejected.own_output")
                        continue
                out.extend(self.decode(RawRecord(raw.protocol, raw.source, raw.t, item.data,
                                                 {"id": item.can_id, "ext": True})))
            elif self._own.names and self._own.message(item.pgn, item.src, item.payload):
                health.count("rejected.own_output")
            else:
                health.count("messages")
                out.extend(self._n2k.decode_message(raw, item.prio, item.pgn, item.src, item.dst, item.payload))
        return out


_PGN_CLAIM = 60928


class _OwnGuard:
    """Which addresses are edged's own: those whose last address claim carried one of
    our NAMEs (a claim by another NAME gives the address back)."""

    __slots__ = ("names", "_addresses")

    def __init__(self, names: frozenset[int]) -> None:
        self.names = names
        self._addresses: set[int] = set()

    def message(self, pgn: int, src: int, payload: bytes) -> bool:
        """Whether a message of `pgn` from `src` is our own (learning from claims)."""
        if pgn == _PGN_CLAIM and len(payload) >= 8:
            if int.from_bytes(payload[:8], "little") in self.names:
                self._addresses.add(src)
                return True
            self._addresses.discard(src)
            return False
        return src in self._addresses

    def frame(self, can_id: int, data: bytes) -> bool:
        """The same for one frame of a bus (60928 is PDU1: PF 0xEE, any destination)."""
        pgn = _PGN_CLAIM if (can_id >> 16) & 0x3FF == _PGN_CLAIM >> 8 else -1
        return self.message(pgn, can_id & 0xFF, data)


def _says_fd(meta: Any) -> bool:
    """Whether a record's meta marks it as a CAN FD frame (`"fd": true`)."""
    get = getattr(meta, "get", None)
    return get is not None and get("fd") is True


def _identifier(meta: Any) -> tuple[int, bool] | None:
    """(id, extended) from a record's meta, checked: MCAP replays bring JSON back."""
    try:
        can_id, ext = meta["id"], meta["ext"]
    except (TypeError, KeyError):
        return None
    if not isinstance(can_id, int) or not isinstance(ext, bool):
        return None
    if not 0 <= can_id < (1 << 29 if ext else 1 << 11):
        return None
    return can_id, ext
