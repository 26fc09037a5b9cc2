"""The mark of the NMEA 2000 output's traffic (`OutputPlugin.own_marks`), in one place.

The output declares its ISO NAME under `OWN_NAME`; the CAN decoder
(`edged_can.decoder`) learns which address each NAME claimed (PGN 60928) and refuses
the frames of an address whose last claim carried one of these NAMEs. Kept apart from
the output's modules so that the decoder imports a constant, not the output.
"""

from __future__ import annotations

__all__ = ["OWN_NAME", "name_hex", "parse_names"]

#: The mark: 64-bit ISO NAMEs as 16 hex digits (lower case).
OWN_NAME = "n2k.name"


def name_hex(name: int) -> str:
    """A NAME as the mark carries it: 16 hex digits."""
    return f"{name:016x}"


def parse_names(marks: object) -> frozenset[int]:
    """The NAMEs of a mark's values; what is not a 64-bit hex number is left out."""
    out = set()
    for v in marks if isinstance(marks, (set, frozenset, list, tuple)) else ():
        try:
            n = int(str(v), 16)
        except ValueError:
            continue
        if 0 <= n < 1 << 64:
            out.add(n)
    return frozenset(out)
