"""A live CAN bus through python-can, kept open against everything a bus does at sea.

A session opens the bus, pumps frames into the event loop (python-can's Notifier and
AsyncBufferedReader), and ends on a bus error, a bus-off error frame, or silence longer
than the watchdog (`SessionEnded`, a `LinkLost`); the caller's `edged.link.Link` then
reopens with exponential backoff. A gateway's `can0` that went down when the NMEA 2000
backbone lost power comes back by itself.
"""

from __future__ import annotations

import asyncio
from typing import Any, Awaitable, Callable

import can

from edged.health import ComponentHealth
from edged.link import LinkLost, LinkState

#: SocketCAN error classes in an error frame's identifier (linux/can/error.h).
CAN_ERR_CRTL = 0x00000004
CAN_ERR_BUSOFF = 0x00000040
CAN_ERR_RESTARTED = 0x00000100

Sleep = Callable[[float], Awaitable[Any]]


class SessionEnded(LinkLost):
    """Why a bus session ended (the link's reason); the message goes to health."""


class _ErrorListener(can.Listener):
    """Turns an exception of python-can's receive thread into a future the pump awaits."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self.failed: asyncio.Future[BaseException] = loop.create_future()

    def on_message_received(self, msg: can.Message) -> None:
        pass

    def on_error(self, exc: Exception) -> None:
        if not self.failed.done():
            self.failed.set_result(exc)


async def pump(
    bus: can.BusABC,
    on_frame: Callable[[can.Message], None],
    health: ComponentHealth,
    watchdog: float,
) -> None:
    """Deliver frames until the bus fails; always raises SessionEnded."""
    loop = asyncio.get_running_loop()
    reader = can.AsyncBufferedReader()
    errors = _ErrorListener(loop)
    # Short receive timeout: Notifier.stop() joins the thread for up to that long.
    notifier = can.Notifier(bus, [reader, errors], timeout=0.05, loop=loop)
    get: asyncio.Future[can.Message] | None = None
    try:
        while True:
            get = asyncio.ensure_future(reader.get_message())
            done, _ = await asyncio.wait(
                (get, errors.failed), timeout=watchdog, return_when=asyncio.FIRST_COMPLETED
            )
            if get not in done:
                if errors.failed.done():
                    health.count("bus.errors")
                    raise SessionEnded(f"bus error: {errors.failed.result()}")
                raise SessionEnded(f"no frame for {watchdog:g} s", state=LinkState.STALE)
            _deliver(get.result(), on_frame, health)
            buffer = reader.buffer
            while not buffer.empty():
                _deliver(buffer.get_nowait(), on_frame, health)
    finally:
        if get is not None:
            get.cancel()
        notifier.stop(timeout=1.0)


def _deliver(msg: can.Message, on_frame: Callable[[can.Message], None], health: ComponentHealth) -> None:
    if msg.is_error_frame:
        _error_frame(msg, health)
    elif msg.is_remote_frame:
        health.count("remote_frames")
    else:
        on_frame(msg)


def _error_frame(msg: can.Message, health: ComponentHealth) -> None:
    """SocketCAN reports controller states as error frames; bus-off needs a reopen."""
    health.count("bus.error_frames")
    cls = msg.arbitration_id
    if cls & CAN_ERR_BUSOFF:
        health.count("bus.bus_off")  # a reason of `disconnected`, not a state of its own
        raise SessionEnded("bus-off")
    if cls & CAN_ERR_CRTL:
        health.error(f"CAN controller problem (error frame data {bytes(msg.data).hex()})")
