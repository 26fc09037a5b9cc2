"""Transports: one module per kind behind the small interface of `base.Transport`.

`make_transport(config)` picks one by `config.transport`; adding a transport is a
module and a line in TRANSPORTS.
"""

from __future__ import annotations

from typing import Any, Callable

from .base import Transport
from .file import FileTransport
from .serial import SerialTransport
from .tcp import TcpTransport
from .udp import UdpTransport

TRANSPORTS: dict[str, Callable[[Any], Transport]] = {
    "serial": SerialTransport.from_config,
    "tcp": TcpTransport.from_config,
    "udp": UdpTransport.from_config,
    "file": FileTransport.from_config,
}


def make_transport(config: Any) -> Transport:
    return TRANSPORTS[config.transport](config)


__all__ = ["Transport", "TRANSPORTS", "make_transport", "FileTransport", "SerialTransport", "TcpTransport", "UdpTransport"]
