"""One `struct.unpack` for a DBC frame whose signals are whole little-endian bytes.

cantools decodes a frame by reversing its bytes, unpacking them with bitstruct and
scaling each signal: about 6 µs a frame inside a replay, the largest single cost of
reading the reference load (six draft marks at 100 Hz and the IMU, DESIGN §9). Most
sensor frames are laid out on byte boundaries, little-endian (ours are), and for those
`struct` does the unpacking in one call. The values are then scaled and named by
cantools' own conversion objects, or by the same expression for a linear one, so
the result is the dict cantools returns, value for value (`tests/can/test_fastdbc.py`
checks every frame of the reference DBC on random data).

Anything else (big-endian or bit-packed signals, multiplexed or container frames, a
frame of another length than the DBC's) is not made fast: `unpacker` returns None,
or the decoder falls back to cantools for that frame.
"""

from __future__ import annotations

import struct
from typing import Any, Callable

from cantools.database.can import Message
from cantools.database.conversion import IdentityConversion, LinearConversion, NamedSignalConversion

__all__ = ["unpacker"]

_INT = {8: "B", 16: "H", 32: "I", 64: "Q"}
_FLOAT = {32: "f", 64: "d"}


def _code(sig: Any) -> str | None:
    if sig.is_float:
        return _FLOAT.get(sig.length)
    c = _INT.get(sig.length)
    return None if c is None else (c.lower() if sig.is_signed else c)


def unpacker(msg: Message) -> Callable[[bytes], dict[str, Any]] | None:
    """`decode(data)`, equal to `msg.decode(data, decode_choices=True)` for `data` of
    the message's length; None when the message's layout is not one struct can read."""
    if msg.is_multiplexed() or msg.is_container or not msg.signals:
        return None
    order = sorted(msg.signals, key=lambda s: s.start)  # as the bytes hold them
    fmt = "<"
    pos = 0  # the next byte the format reads
    for sig in order:
        code = _code(sig)
        if sig.byte_order != "little_endian" or code is None or sig.start % 8 or sig.start // 8 < pos:
            return None
        fmt += "x" * (sig.start // 8 - pos) + code
        pos = sig.start // 8 + sig.length // 8
    if pos > msg.length:
        return None
    fmt += "x" * (msg.length - pos)
    layout = struct.Struct(fmt)
    index = {s.name: i for i, s in enumerate(order)}
    # (name, place in the unpacked tuple, how, scale, offset, choices or conversion):
    # the signals in the message's order, as cantools fills its dict. How: 0 as it is,
    # 1 linear (scale, offset), 2 cantools' own conversion, 3 a named value or as it
    # is, 4 a named value or linear (NamedSignalConversion over those two)
    plan: list[tuple[str, int, int, Any, Any, Any]] = []
    for sig in msg.signals:
        conv = sig.conversion
        inner = getattr(conv, "_conversion", None).__class__ if conv.__class__ is NamedSignalConversion else None
        if conv.__class__ is IdentityConversion:
            plan.append((sig.name, index[sig.name], 0, None, None, None))
        elif conv.__class__ is LinearConversion:
            plan.append((sig.name, index[sig.name], 1, conv.scale, conv.offset, None))
        elif inner is IdentityConversion and isinstance(conv.choices, dict):
            plan.append((sig.name, index[sig.name], 3, None, None, conv.choices))
        elif inner is LinearConversion and isinstance(conv.choices, dict):
            plan.append((sig.name, index[sig.name], 4, conv.scale, conv.offset, conv.choices))
        else:  # the rest: cantools' own
            plan.append((sig.name, index[sig.name], 2, None, None, conv.raw_to_scaled))
    unpack = layout.unpack
    steps = tuple(plan)

    def decode(data: bytes) -> dict[str, Any]:
        raw = unpack(data)
        out: dict[str, Any] = {}
        for name, i, how, scale, offset, conv in steps:
            v = raw[i]
            if how == 1:
                v = v * scale + offset  # LinearConversion.raw_to_scaled
            elif how >= 3:  # NamedSignalConversion.raw_to_scaled
                choice = conv.get(int(v))
                if choice is not None:
                    v = choice
                elif how == 4:
                    v = v * scale + offset
            elif how == 2:
                v = conv(v, True)
            out[name] = v
        return out

    return decode
