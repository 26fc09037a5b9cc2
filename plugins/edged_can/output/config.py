"""Configuration of the NMEA 2000 output (`[outputs.<name>]`, `type = "nmea2000"`).

Where the PGNs go (`transport`): a CAN bus through python-can (`can`, with the CAN
input's `interface`/`channel`/`bitrate`), a Yacht Devices gateway in RAW mode over TCP
(`ydwg`), or an Actisense NGT-1/NGX over its serial port or a TCP relay of it
(`actisense`). Who we are on the bus: the preferred source `address` and the ISO NAME's
fields (`unique_number` ... `industry_group`), which other devices and edged's own
inputs (the loop guard) recognise us by.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from edged.config import ReconnectSettings
from edged.bridgeoutput import BridgeOutputConfig

__all__ = ["Nmea2000OutputConfig", "WATER_REFERENCE"]

#: canboat's WATER_REFERENCE codes (PGN 128259's speed type), by our names.
WATER_REFERENCE = {"paddle_wheel": 0, "pitot_tube": 1, "doppler": 2, "correlation": 3, "electro_magnetic": 4}
#: Default TCP port of each gateway: YDWG RAW 1457; an Actisense relay has none.
DEFAULT_PORT = {"ydwg": 1457}


class Nmea2000OutputConfig(BridgeOutputConfig, ReconnectSettings):
    #: `can`: a python-can bus (edged claims an address on it); `ydwg`: YDWG-02/YDEN-02
    #: RAW over TCP; `actisense`: Actisense BST (NGT-1) over serial or TCP. A gateway
    #: sends with its own address: only `can` claims one.
    transport: Literal["can", "ydwg", "actisense"] = "can"
    #: No PGN of this output carries drafts: none is read unless named.
    draft: str = ""
    #: can: the python-can interface (SocketCAN on board, `virtual` in tests).
    interface: Literal["socketcan", "virtual"] = "socketcan"
    #: can: the SocketCAN interface (`can0`) or the virtual bus's channel name.
    channel: str = "can0"
    #: can: bits per second of the bus.
    bitrate: int = Field(250_000, gt=0, le=16_000_000)
    #: ydwg / actisense over TCP: the gateway's (or relay's) address.
    host: str | None = None
    #: ydwg / actisense over TCP: its port (YDWG RAW: 1457 when not given).
    port: int | None = Field(None, ge=1, le=65535)
    #: actisense over a serial port: the device (`/dev/ttyUSB0`, or a pyserial URL).
    device: str | None = None
    #: actisense over a serial port: its speed (Bd).
    baudrate: int = Field(115200, ge=300, le=4_000_000)
    #: Preferred source address; another is claimed when a device with a higher
    #: priority NAME holds it (0-251; 252-253 are reserved, 254 "no address").
    address: int = Field(35, ge=0, le=251)
    #: ISO NAME: a number unique among the devices of this manufacturer code (21 bits).
    unique_number: int = Field(0x0EDED, ge=0, le=(1 << 21) - 1)
    #: ISO NAME: the manufacturer code (11 bits; 2046 is no registered manufacturer's).
    manufacturer_code: int = Field(2046, ge=0, le=2047)
    #: ISO NAME: the device function (170 "Integrated Navigation" of class 60).
    device_function: int = Field(170, ge=0, le=255)
    #: ISO NAME: the device class (60 "Navigation").
    device_class: int = Field(60, ge=0, le=127)
    #: ISO NAME: the instance of this device (8 bits), when several are on the bus.
    device_instance: int = Field(0, ge=0, le=255)
    #: ISO NAME: the instance of its system (4 bits).
    system_instance: int = Field(0, ge=0, le=15)
    #: ISO NAME: the industry group (4: marine, as NMEA 2000 devices are).
    industry_group: int = Field(4, ge=0, le=7)
    #: PGN 128259's water-speed sensor type; none of them is a fused estimate, so the
    #: field says "no data" unless told.
    stw_sensor_type: Literal["paddle_wheel", "pitot_tube", "doppler", "correlation", "electro_magnetic"] | None = None
    #: Seconds between heartbeats (PGN 126993) of clock time; 0: none.
    heartbeat: float = Field(60.0, ge=0.0, le=65.532)
    #: Product information (PGN 126996): the model version (at most 32 characters;
    #: the model is "edged", the software version edged's).
    model_version: str = Field("", max_length=32)
    #: Product information: the serial code (at most 32 characters).
    serial: str = Field("", max_length=32)
    #: Product information: the product code.
    product_code: int = Field(0, ge=0, le=65533)
    #: Bytes that may wait for a gateway link before messages are dropped.
    link_buffer: int = Field(65536, ge=1024, le=64 * 1024 * 1024)


    @model_validator(mode="after")
    def _where(self) -> "Nmea2000OutputConfig":
        t = self.transport
        if t == "ydwg" and not self.host:
            raise ValueError('transport = "ydwg" needs the gateway\'s host (and port, default 1457)')
        if t == "actisense" and not (self.device or (self.host and self.port)):
            raise ValueError('transport = "actisense" needs a serial device, or a host and port of a TCP relay')
        if t == "actisense" and self.device and self.host:
            raise ValueError('transport = "actisense": give either a serial device or a host, not both')
        return self

    def gateway_port(self) -> int | None:
        """The TCP port of the gateway (the configured one, YDWG's 1457 by default)."""
        return self.port if self.port is not None else DEFAULT_PORT.get(self.transport)

    def where(self) -> str:
        """The link in words, for health and errors."""
        if self.transport == "can":
            return f"{self.interface} bus {self.channel!r}"
        if self.device:
            return f"{self.transport} serial {self.device} @ {self.baudrate} Bd"
        return f"{self.transport} tcp {self.host}:{self.gateway_port()}"
