"""Actisense "N2K ASCII" (NGX, W2K-1 in ASCII mode): `A<timer> <SSDDP> <PGN> <hex data>`, a whole message a line.

`A173321.107 23FF7 1F513 012F3070002F30709F`: the gateway's timer; five hex digits
packing source (2), destination (2) and priority (1); the PGN in hex (5 or 6 digits);
the payload in hex (the gateway reassembled fast-packets: up to 223 bytes). The same
line without the `A<timer>` field (the "raw" variant) is read alike.

The timer is read neither as a time of day (Actisense's documents say hhmmss.ddd,
canboat's samples hold `A764027.880`) nor as anything else: a live record is stamped
by the input's clock, as a bus frame is. A raw record keeps the line as it came.

Ours: the `nmea2000` package's `N2kAsciiDecoder` reads the same lines (and its
`N2kAsciiEncoder` writes them, used by the tests), but returns its own message objects
without a reason when a line is bad; our decoder needs (prio, PGN, src, dst, data).
"""

from __future__ import annotations

import re

from . import Bad, Message

NAME = "actisense_ascii"
_LINE = re.compile(rb"\s*(?:A(\d{1,10})(?:\.(\d{1,3}))? +)?([0-9A-Fa-f]{5}) +([0-9A-Fa-f]{1,6}) +([0-9A-Fa-f]*)\s*")
MAX_PGN = 0x3FFFF
MAX_LENGTH = 223


def frame(data: bytes) -> list[Message]:
    m = _LINE.fullmatch(data)
    if m is None:
        raise Bad("bad_line", f"not an Actisense N2K ASCII line: {data[:60]!r}")
    sdp = int(m.group(3), 16)
    pgn = int(m.group(4), 16)
    if pgn > MAX_PGN:
        raise Bad("bad_pgn", f"PGN {pgn} beyond 18 bits")
    hexdata = m.group(5)
    if len(hexdata) % 2:
        raise Bad("bad_length", f"PGN {pgn}: odd number of hex digits ({len(hexdata)})")
    payload = bytes.fromhex(hexdata.decode())
    if not payload or len(payload) > MAX_LENGTH:
        raise Bad("bad_length", f"PGN {pgn} with {len(payload)} data bytes (1 to {MAX_LENGTH})")
    prio = sdp & 0xF
    if prio > 7:
        raise Bad("bad_line", f"priority {prio} (0 to 7)")
    return [Message(prio, pgn, (sdp >> 12) & 0xFF, (sdp >> 4) & 0xFF, payload)]
