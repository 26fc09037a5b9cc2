"""Shipmodul MiniPlex `$MXPGN` sentences: one NMEA 2000 frame in NMEA 0183 framing.

    $MXPGN,<PGN, 6 hex>,<attribute, 4 hex>,<data hex>*hh
    attribute: bit 15 = sent by the gateway, bits 14-12 = priority, 11-8 = data length,
               7-0 = source address (of a received frame)

The data bytes are written most significant first, the reverse of the bus order (so
`$MXPGN,01F801,2801,C1308AC40C5DE343` is PGN 129025 from address 1 with bus bytes
43 E3 5D 0C C4 8A 30 C1: 20.748° N, 105.378° W; the `nmea2000` package reads it the same
way). A frame the gateway itself sent (bit 15) is ours, not the bus's: counted
`gateway_tx`, not decoded. Fast-packet PGNs come frame by frame, as on the bus.
"""

from __future__ import annotations

import re

from . import Bad, Frame, Message, can_id, check_sum

NAME = "mxpgn"
_SENTENCE = re.compile(rb"\$(MXPGN,([0-9A-Fa-f]{6}),([0-9A-Fa-f]{4}),((?:[0-9A-Fa-f]{2}){1,8}))\*([0-9A-Fa-f]{2})")
MAX_PGN = 0x1FFFF


def frame(data: bytes) -> list[Frame | Message]:
    m = _SENTENCE.fullmatch(data.strip())
    if m is None:
        raise Bad("bad_line", f"not a $MXPGN sentence: {data[:60]!r}")
    check_sum(m.group(1), m.group(5))
    pgn, attr = int(m.group(2), 16), int(m.group(3), 16)
    payload = bytes.fromhex(m.group(4).decode("ascii"))[::-1]
    if pgn > MAX_PGN:
        raise Bad("bad_pgn", f"$MXPGN PGN 0x{pgn:x} is beyond NMEA 2000's 0x1FFFF")
    if (attr >> 8) & 0xF != len(payload):
        raise Bad("bad_length", f"$MXPGN PGN {pgn}: length {(attr >> 8) & 0xF} but {len(payload)} data bytes")
    if attr & 0x8000:
        raise Bad("gateway_tx", f"$MXPGN PGN {pgn} sent by the gateway")
    prio, src = (attr >> 12) & 0x7, attr & 0xFF
    return [Frame(can_id(prio, pgn, src, 255), payload)]
