"""SeaSmart `$PCDIN` sentences: a whole NMEA 2000 message in NMEA 0183 framing.

    $PCDIN,<PGN, 6 hex>,<gateway timer, 8 base-32 digits>,<source, 2 hex>,<payload hex>*hh

The gateway reassembles fast-packets, so each sentence is a `Message`; the payload is
in bus byte order. In a log, the NMEA 0183 reader frames these lines (checksum, TAG
block, time) and hands them to this framer; live, the `n2k_gateway` input does, and
the framer checks the checksum itself, in a log of their own or mixed with other sentences;
the gateway's timer is not used (the line's time is the log's). The priority is not
carried: 2, which does not change what a message means.
"""

from __future__ import annotations

import re

from . import Bad, Frame, Message, check_sum

NAME = "pcdin"
_SENTENCE = re.compile(rb"\$(PCDIN,([0-9A-Fa-f]{6}),([0-9A-Va-v]{8}),([0-9A-Fa-f]{2}),((?:[0-9A-Fa-f]{2})*))\*([0-9A-Fa-f]{2})")
MAX_LENGTH = 223
MAX_PGN = 0x1FFFF


def frame(data: bytes) -> list[Frame | Message]:
    m = _SENTENCE.fullmatch(data.strip())
    if m is None:
        raise Bad("bad_line", f"not a $PCDIN sentence: {data[:60]!r}")
    check_sum(m.group(1), m.group(6))
    pgn, src = int(m.group(2), 16), int(m.group(4), 16)
    payload = bytes.fromhex(m.group(5).decode("ascii"))
    if pgn > MAX_PGN:
        raise Bad("bad_pgn", f"$PCDIN PGN 0x{pgn:x} is beyond NMEA 2000's 0x1FFFF")
    if not 0 < len(payload) <= MAX_LENGTH:
        raise Bad("bad_length", f"$PCDIN PGN {pgn}: {len(payload)} bytes")
    return [Message(2, pgn, src, 255, payload)]
