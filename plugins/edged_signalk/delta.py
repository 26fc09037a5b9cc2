"""One Signal K delta as the bytes of one line.

A delta says which vessel (`context`), who says it (`$source`), when (the
estimate's data time, not the moment it is sent: a replay's deltas carry the
voyage's times) and the values (`paths`). One delta a line, ended by CR LF, the
framing of signalk-server's "Signal K over TCP" connection (it splits on line
ends); over UDP one delta a datagram.

The source is a `$source` string, `edged.<output name>`: signalk-server keeps it as
it is and shows it beside each value in its REST API. A `source` object would not
do: the server overwrites its label with the data connection's id.
"""

from __future__ import annotations

import math
import time

import orjson

from .paths import Values

__all__ = ["iso_ms", "encode_delta"]


def iso_ms(t: float) -> str:
    """UNIX seconds as ISO 8601 UTC with milliseconds (`2024-05-01T12:00:00.123Z`),
    truncated to the millisecond; ValueError/OverflowError/OSError for a time no
    calendar holds."""
    ms = math.floor(t * 1000.0)
    sec, frac = divmod(ms, 1000)
    return time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(sec)) + f".{frac:03d}Z"


def encode_delta(context: str, source: str, timestamp: str, values: Values) -> bytes:
    """The delta's line: one update of `values` (None goes out as null)."""
    doc = {
        "context": context,
        "updates": [{
            "$source": source,
            "timestamp": timestamp,
            "values": [{"path": p, "value": v} for p, v in values],
        }],
    }
    return orjson.dumps(doc) + b"\r\n"
