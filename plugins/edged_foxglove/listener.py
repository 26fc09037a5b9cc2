"""Who is watching: the server's subscriptions, as the SDK reports them.

The SDK calls its `ServerListener` from its own threads (after releasing its locks),
so this keeps a small table of (client, channel) pairs under a lock of its own and
never touches the component's health (whose counters belong to the event loop):
`status()` reads the table. A waiter in the event loop (`until`, for tests and
tools that must not publish before a browser listens) is woken through the loop's
thread-safe call, never by polling.

A client that is connected but subscribed to nothing is not seen: the SDK reports
subscriptions, not connections (a browser subscribes to what its panels show).
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any, Callable

from foxglove.websocket import ServerListener

__all__ = ["Subscriptions"]


class Subscriptions(ServerListener):
    """The live subscriptions of one server; safe to call from any thread."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop
        self._lock = threading.Lock()
        self._pairs: set[tuple[int, int]] = set()  # (client id, channel id)
        self._topics: dict[int, str] = {}  # channel id -> topic
        self._subscribes = 0
        self._changed = asyncio.Event()

    # -- the SDK's side (its threads) ---------------------------------------------------
    def on_subscribe(self, client: Any, channel: Any) -> None:
        with self._lock:
            self._pairs.add((int(client.id), int(channel.id)))
            self._topics[int(channel.id)] = str(channel.topic)
            self._subscribes += 1
        self._notify()

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        with self._lock:
            self._pairs.discard((int(client.id), int(channel.id)))
        self._notify()

    def _notify(self) -> None:
        try:
            self._loop.call_soon_threadsafe(self._changed.set)
        except RuntimeError:  # the loop is closed: nobody waits any more
            pass

    # -- the event loop's side -----------------------------------------------------------
    def counts(self) -> dict[str, int]:
        """Clients with at least one subscription, live subscriptions, subscribes so far."""
        with self._lock:
            return {
                "clients": len({c for c, _ in self._pairs}),
                "subscriptions": len(self._pairs),
                "subscribes": self._subscribes,
            }

    def watchers(self, topic: str) -> int:
        """Clients subscribed to `topic` now."""
        with self._lock:
            return sum(1 for _, ch in self._pairs if self._topics.get(ch) == topic)

    async def until(self, cond: Callable[[], bool]) -> None:
        """Return once `cond()` holds, looked at after each change of subscriptions."""
        while not cond():
            self._changed.clear()
            if cond():  # (a change between the look and the clear)
                return
            await self._changed.wait()
