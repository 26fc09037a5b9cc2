"""The latest record of every key, for the queryable on `vessel/<id>/**`.

Written by the event loop (once per batch, under a lock), read by zenoh's own thread
when a query arrives. Records are kept as they are and encoded only when asked for:
queries are rare, records are many.
"""

from __future__ import annotations

import threading
from typing import Any, Iterable

import zenoh

__all__ = ["LatestValues"]


class LatestValues:
    """Thread-safe map key -> (KeyExpr, latest record)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._items: dict[str, tuple[zenoh.KeyExpr, Any]] = {}

    def update(self, pairs: Iterable[tuple[str, Any]]) -> None:
        """Store many (key, record) pairs under one lock acquisition."""
        items = self._items
        with self._lock:
            for key, rec in pairs:
                old = items.get(key)
                items[key] = (old[0] if old is not None else zenoh.KeyExpr(key), rec)

    def matching(self, selector: zenoh.KeyExpr) -> list[tuple[str, Any]]:
        """(key, record) of every stored key that intersects `selector`."""
        with self._lock:
            snapshot = list(self._items.items())
        return [(k, rec) for k, (kexpr, rec) in snapshot if selector.intersects(kexpr)]

    def __len__(self) -> int:
        return len(self._items)
