"""Configuration of an NMEA 0183 input (one `[inputs.<name>]` table).

Per-transport requirements are checked by field validators (not a model validator)
so that every error carries the key it is about: `inputs.gnss1.host: required when
transport is 'tcp'` rather than a message about the table as a whole.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, ValidationInfo, field_validator

from edged.config import MAX_WATCHDOG, ReconnectSettings
from edged.plugin import Claim, InputConfig, listen_claim, serial_claim

Transport = Literal["serial", "tcp", "udp", "file"]
ChecksumPolicy = Literal["require", "allow-missing", "ignore"]

#: Which keys each transport needs; the validators below read this table.
REQUIRED_KEYS: dict[str, tuple[str, ...]] = {
    "serial": ("device",),
    "tcp": ("host", "port"),
    "udp": ("port",),
    "file": ("path",),
}


class Nmea0183Config(InputConfig, ReconnectSettings):
    """Settings of one NMEA 0183 input; unknown keys are errors (InputConfig)."""

    #: Declared first: the per-transport validators of later fields read it.
    transport: Transport
    device: str | None = Field(None, validate_default=True)
    baudrate: int = Field(4800, gt=0, le=4_000_000)
    host: str | None = Field(None, validate_default=True)
    port: int | None = Field(None, ge=1, le=65535, validate_default=True)
    #: UDP: the local address to listen on. Loopback by default, so that a gateway
    #: does not accept sentences from the whole network unless told to.
    bind: str = "127.0.0.1"
    #: UDP: receive broadcast datagrams (binds to all addresses of the port).
    broadcast: bool = False
    path: str | None = Field(None, validate_default=True)
    checksum: ChecksumPolicy = "require"
    #: Seconds a live link may stay open without a byte before it is reopened.
    watchdog: float = Field(10.0, gt=0, le=MAX_WATCHDOG)
    #: Magnetic variation in degrees (east positive), used when no sentence gives one.
    variation: float | None = Field(None, ge=-180.0, le=180.0)
    #: Emit the ground part of VBW as `velocity_ground` (off: GNSS is the better source).
    vbw_ground: bool = False
    #: UDP: receive buffer in bytes (SO_RCVBUF); None keeps the system default. Linux
    #: doubles it and caps it at 2 × net.core.rmem_max (a warning says so).
    rcvbuf: int | None = Field(None, ge=4096, le=2**31 - 1)

    @field_validator("device", "host", "port", "path")
    @classmethod
    def _required_by_transport(cls, v: object, info: ValidationInfo) -> object:
        transport = info.data.get("transport")
        if v is None and transport is not None and info.field_name in REQUIRED_KEYS[transport]:
            raise ValueError(f"required when transport is {transport!r}")
        return v

    def claims(self) -> list[Claim]:
        """A UDP port it listens on, a serial device it reads: one input each.

        Two UDP listeners on one port would each get a share of the datagrams (or the
        second would not start); two readers of one tty steal bytes from each other.
        A TCP input is a client (a multiplexer serves many) and a file is only read.
        """
        if self.transport == "udp" and self.port is not None:
            return [listen_claim("port", "udp", self.bind, self.port)]
        if self.transport == "serial" and self.device:
            return serial_claim(self.device, text=f"read serial {self.device}")
        return []
