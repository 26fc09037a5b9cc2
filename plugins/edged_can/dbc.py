"""DBC-described frames -> measurements, through the configured signal mappings.

The mappings are compiled once into a table keyed by (frame id, extended), so the hot
path is one dict lookup, one cantools decode and one validated measurement per
mapping. A signal value the DBC names as a choice (e.g. `0xFFFF "unavailable"`) means
"no reading" for a physical field and is counted; for a code field (unit "1", like a
draft's status) the choice's number is the value.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import cantools
from cantools.database.can import Message
from cantools.database.namedsignalvalue import NamedSignalValue

from edged.health import ComponentHealth
from edged.records import KINDS, Measurement, RawRecord

from .config import CanConfig, SignalMap
from .emit import Emitter
from .fastdbc import unpacker


@dataclass(frozen=True, slots=True)
class _Binding:
    kind: str
    source: str
    mark: str | None
    #: (kind field, signal, is_code)
    fields: tuple[tuple[str, str, bool], ...]
    unavailable_key: str


@dataclass(slots=True)
class _Frame:
    message: Message
    bindings: tuple[_Binding, ...]
    counter: str | None
    frames_key: str
    lost_key: str
    last_counter: int | None = None
    #: `fastdbc.unpacker`'s decoder for data of the DBC's length (None: cantools' own)
    fast: Callable[[bytes], dict[str, Any]] | None = None
    length: int = -1  # the DBC's data length, for the fast decoder


def _binding(sm: SignalMap, bus: str) -> _Binding:
    units = {f.name: f.unit for f in KINDS[sm.kind].fields}
    return _Binding(
        kind=sm.kind,
        source=sm.source.format(bus=bus, message=sm.message),
        mark=sm.mark,
        fields=tuple((k, sig, units[k] == "1") for k, sig in sm.fields.items()),
        unavailable_key=sm.message,
    )


#: Measurement kinds that carry a frame counter's `lost` (DESIGN §2): those that
#: define the field.
LOST_KINDS = frozenset(k for k, spec in KINDS.items() if "lost" in spec.field_names)


def _values(b: _Binding, sig: dict[str, object]) -> dict[str, object] | None:
    """The measurement's values, or None when a physical signal says "not available"."""
    values: dict[str, object] = {} if b.mark is None else {"mark": b.mark}
    for field, name, is_code in b.fields:
        v = sig[name]
        if isinstance(v, NamedSignalValue):
            if not is_code:
                return None
            v = v.value
        values[field] = v
    return values


class DbcDecoder:
    def __init__(self, bus: str, config: CanConfig, health: ComponentHealth, emit: Emitter) -> None:
        self._health = health
        self._emit = emit
        db = config.database
        frames: dict[tuple[int, bool], _Frame] = {}
        for sm in config.signals:
            msg = db.get_message_by_name(sm.message)
            key = (msg.frame_id, bool(msg.is_extended_frame))
            fr = frames.get(key)
            if fr is None:
                fr = frames[key] = _Frame(
                    msg, (), sm.counter, f"dbc.{msg.name}", f"dbc.lost.{msg.name}", fast=unpacker(msg),
                    length=msg.length,
                )
            fr.bindings += (_binding(sm, bus),)
            fr.counter = fr.counter or sm.counter
        self._frames = frames

    def knows(self, frame_id: int, ext: bool) -> bool:
        return (frame_id, ext) in self._frames

    def is_fd(self, frame_id: int, ext: bool) -> bool:
        """Whether the DBC defines this frame as a CAN FD one (up to 64 data bytes)."""
        fr = self._frames.get((frame_id, ext))
        return fr is not None and bool(fr.message.is_fd)

    def decode(self, raw: RawRecord, frame_id: int, ext: bool) -> list[Measurement]:
        fr = self._frames[(frame_id, ext)]
        data = raw.data
        try:
            if fr.fast is not None and len(data) == fr.length:
                sig = fr.fast(data)
            else:  # (cantools says what is wrong with a frame of another length)
                sig = fr.message.decode(data, decode_choices=True)
        except (cantools.database.DecodeError, ValueError, IndexError) as exc:
            self._health.count("rejected.dbc_frame")
            self._health.error(f"{fr.message.name}: cannot decode {raw.data.hex()} ({exc})")
            return []
        self._health.count(fr.frames_key)
        lost = None if fr.counter is None else self._check_counter(fr, int(sig[fr.counter]))
        out: list[Measurement] = []
        t = raw.t
        for b in fr.bindings:
            values = _values(b, sig)
            if values is None:
                self._emit.unavailable(b.unavailable_key)
            else:
                if lost is not None and b.kind in LOST_KINDS:
                    values["lost"] = lost  # the sensor's own count: what timing cannot tell
                self._emit(out, b.kind, b.source, t, values)
        return out

    def _check_counter(self, fr: _Frame, counter: int) -> int | None:
        """An 8-bit counter +1 per frame: a gap of n means n frames lost on the way.
        The frames lost before this one (None: the first, or a repeat)."""
        last = fr.last_counter
        fr.last_counter = counter
        if last is None:
            return None
        gap = (counter - last - 1) & 0xFF
        if gap == 0xFF:  # the same counter again: a repeated frame
            self._health.count("dbc.repeated")
            return None
        if gap:
            self._health.count("dbc.lost", gap)
            self._health.count(fr.lost_key, gap)
        return gap
