"""Configuration of the live Foxglove output (`[outputs.<name>] type = "foxglove"`).

The server is a window into the vessel for a browser on board: it listens on this
machine only unless told otherwise (`host`), and measurements, which can come at
100 Hz (the draft marks), are thinned per channel on data time so that a slow link
to the browser is not flooded; estimates and health go out as they come.
"""

from __future__ import annotations

import ipaddress
import re

from pydantic import Field, field_validator

from edged.plugin import Claim, OutputConfig, listen_claim
from edged.ratelimit import MeasurementRates

__all__ = ["FoxgloveOutputConfig"]

#: A DNS name: labels of letters, digits and hyphens, dot separated.
_LABEL = r"[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
_HOSTNAME = re.compile(rf"^(?=.{{1,253}}$){_LABEL}(\.{_LABEL})*$")


class FoxgloveOutputConfig(OutputConfig, MeasurementRates):
    """Where the WebSocket server listens and which records it serves."""

    type: str = "foxglove"
    #: The address to listen on: this machine only by default; "0.0.0.0" for every
    #: interface (anyone on the ship's network may then watch).
    host: str = "127.0.0.1"
    #: The TCP port (8765 is Foxglove's default); 0 lets the kernel choose one,
    #: shown in health as `info.url` (tests).
    port: int = Field(8765, ge=0, le=65535)
    #: Serve the estimates (`/est/<name>`), at every estimate.
    estimates: bool = True
    #: Serve the measurements (`/meas/<kind>/<source>`), rate-limited below.
    measurements: bool = True
    #: Serve positions as `foxglove.LocationFix` (`/location/<source>`) for the map,
    #: at the position measurements' rate.
    locations: bool = True
    #: Serve the health snapshots (`/health`).
    health: bool = True
    #: Messages queued per browser before the oldest is dropped (the SDK's backlog):
    #: a browser that falls behind loses old data, never holds the daemon.
    backlog: int = Field(1024, ge=1, le=1_000_000)

    @field_validator("host")
    @classmethod
    def _host(cls, v: str) -> str:
        v = v.strip()
        if v.startswith("[") and v.endswith("]"):
            v = v[1:-1]
        try:
            return str(ipaddress.ip_address(v))
        except ValueError:
            pass
        if not _HOSTNAME.match(v):
            raise ValueError(f"{v!r} is not an IP address or a host name")
        return v


    def claims(self) -> list[Claim]:
        """The TCP port it listens on (a port 0 asks for any free one: no claim)."""
        out = super().claims()
        if self.port:
            out.append(listen_claim("port", "tcp", self.host, self.port))
        return out
