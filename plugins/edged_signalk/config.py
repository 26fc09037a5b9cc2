"""The `[outputs.signalk]` table: which vessel the deltas are about, where they go.

A Signal K server (signalk-server, its "Signal K" data connection over TCP or UDP)
reads the deltas; everything else (rates, the estimator instances, the transport,
the reconnect delays) is the bridge outputs' common configuration.
"""

from __future__ import annotations

import re

from pydantic import Field, field_validator

from edged.bridgeoutput import BridgeOutputConfig
from edged.bytesinks import TransportSettings

__all__ = ["SignalKOutputConfig", "CONTEXT_RE", "DEFAULT_PORT"]

#: Not NMEA 0183's 10110: a server that also reads sentences on it would get both.
DEFAULT_PORT = 10111

#: What a delta's context may be: the server's own vessel, or a vessel by its URN
#: (an MMSI, or a Signal K UUID), as the Signal K specification spells them.
CONTEXT_RE = re.compile(
    r"vessels\.(self"
    r"|urn:mrn:imo:mmsi:[0-9]{9}"
    r"|urn:mrn:signalk:uuid:[0-9a-fA-F]{8}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{12})"
)


class SignalKOutputConfig(BridgeOutputConfig, TransportSettings):
    #: The vessel the deltas are about: "vessels.self" (the server's own vessel,
    #: whatever its MMSI or UUID), or "vessels.urn:mrn:imo:mmsi:<9 digits>", or
    #: "vessels.urn:mrn:signalk:uuid:<uuid>".
    context: str = "vessels.self"
    #: udp: the server's port; tcp: the port served for the server to connect to.
    port: int = Field(DEFAULT_PORT, ge=0, le=65535)
    #: Deltas per second of data time, by message (speed, current, heading, course,
    #: draft); the defaults: heading 5, the others 1. 0 switches one off.
    rates: dict[str, float] = Field(default_factory=dict)


    @field_validator("context")
    @classmethod
    def _context(cls, v: str) -> str:
        if not CONTEXT_RE.fullmatch(v):
            raise ValueError(
                f"context {v!r} is not a vessel's: use \"vessels.self\", "
                "\"vessels.urn:mrn:imo:mmsi:<9 digits>\" or \"vessels.urn:mrn:signalk:uuid:<uuid>\"")
        return v
