"""NMEA 0183 text for tests that write logs or send datagrams: one checksum helper."""

from __future__ import annotations

from functools import reduce
from operator import xor


def sentence(body: str, start: str = "$") -> str:
    """`sentence("GPHDT,1.0,T")` -> `$GPHDT,1.0,T*XX` with its checksum (no line end)."""
    return f"{start}{body}*{reduce(xor, body.encode(), 0):02X}"
