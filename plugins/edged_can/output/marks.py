"""The mark of the NMEA 2000 output's traffic (`OutputPlugin.own_marks`), in one place.

The output declares its ISO NAME under `OWN_NAME`; the CAN decoder
(`edged_can.decoder`) learns which address each NAME claimed (PGN 60928) and refuses
the frames of an address whose last claim carried one of these NAMEs. Kept apart from
the output's modules so that the decoder imports a constant, not the output.
"""

from __future__ import annotations

__all__ = ["OWN_NAME", "OWN_GATEWAY_TX", "name_hex", "parse_names", "parse_pgns"]

#: The mark: 64-bit ISO NAMEs as 16 hex digits (lower case).
OWN_NAME = "n2k.name"
#: The mark of what edged sends through a YDWG gateway: the PGNs (decimal). The
#: gateway sends them with its own address and NAME and echoes them to its readers
#: as `T` lines: a `T` frame of one of these PGNs is edged's own.
OWN_GATEWAY_TX = "n2k.gateway_tx"


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


def parse_pgns(marks: object) -> frozenset[int]:
    """The PGNs of a mark's values; what is not a PGN (0 to 2^18 - 1) is left out."""
    out = set()
    for v in marks if isinstance(marks, (set, frozenset, list, tuple)) else ():
        try:
            n = int(str(v))
        except ValueError:
            continue
        if 0 <= n < 1 << 18:
            out.add(n)
    return frozenset(out)
