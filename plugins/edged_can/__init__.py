"""edged's CAN input: NMEA 2000 (29-bit, fast-packet) and DBC-described frames (11-bit).

One package, one bus per configured input. Frames become `RawRecord("can", <bus>, t,
data, meta={"id", "ext"})`; a per-bus decoder turns raw records into measurements, so
that live input, candump replay and MCAP replay share the very same decoding.
"""

from .plugin import CanInput

__all__ = ["CanInput"]
