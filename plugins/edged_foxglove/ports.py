"""Waiting for the SDK's server to let go of its port.

`WebSocketServer.stop()` returns before the server's listening socket is closed (its
tasks end on the SDK's own threads, usually within a millisecond), and the SDK offers
nothing to await. A close that returned while the port is still held would make the
next open (the runtime's restart, a reload) fail with "address in use". So close
waits, in a thread and bounded, until a socket can be bound to the port again (with
SO_REUSEADDR, as the server binds it: connections in TIME_WAIT do not count, a
listener does).
"""

from __future__ import annotations

import socket
import time

__all__ = ["port_free", "wait_released"]

#: Seconds between two looks while waiting.
_STEP = 0.002


def port_free(host: str, port: int) -> bool:
    """True when nothing listens on (host, port) of this machine."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    s = socket.socket(family, socket.SOCK_STREAM)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((host, port))
        return True
    except OSError:
        return False
    finally:
        s.close()


def wait_released(host: str, port: int, timeout: float) -> bool:
    """Block (in a worker thread) until (host, port) is free, at most `timeout`
    seconds; whether it was freed."""
    deadline = time.monotonic() + timeout
    while not port_free(host, port):
        if time.monotonic() >= deadline:
            return False
        time.sleep(_STEP)
    return True
