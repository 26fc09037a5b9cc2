"""Thin adapter over the `nmea2000` library: canboat's PGN definitions, nothing more.

Why a library: the field layouts, resolutions and "data not available" sentinels of
NMEA 2000 PGNs are canboat's reverse-engineered knowledge; copying them by hand would
freeze its bugs into our code. Why an adapter: the library's public decoder wants its
own input formats and reassembles fast-packets without saying why a message was
dropped, while edged must count lost / out-of-order / repeated frames. So only two of
its functions are used — identifier decomposition and decoding of one complete payload
— and only this module imports it, so that a change of library touches one file.
"""

from __future__ import annotations

from typing import Any

from nmea2000 import _canboat as canboat
from nmea2000 import backend

__all__ = ["split_id", "is_fast", "decode_fields"]


def split_id(can_id: int) -> tuple[int, int, int, int]:
    """(priority, PGN, source, destination) of a 29-bit identifier.

    PDU1 (PF < 240): the PS byte is the destination and not part of the PGN;
    PDU2: PS is part of the PGN and the message is broadcast (destination 255).
    """
    return canboat.can_id_decompose(can_id & 0x1FFFFFFF)


def is_fast(pgn: int) -> bool | None:
    """Whether `pgn` travels as a fast-packet; None when canboat does not know it."""
    return backend.is_fast_pgn(pgn)


def decode_fields(pgn: int, payload: bytes, src: int, dst: int, prio: int) -> dict[str, Any] | None:
    """Field id -> value of one complete payload, SI units (rad, m/s, m, s).

    Values canboat reports as "data not available" (and fields beyond a short payload)
    are None. Lookups give their code, dates days since 1970-01-01 and times seconds
    since midnight (the library's `raw_value`), so that callers compare numbers, not
    labels. None when canboat cannot decode the payload at all.
    """
    msg = backend.decode(pgn, payload, src, dst, prio, "si")
    if msg is None:
        return None
    return {f.id: f.raw_value for f in msg.fields}
