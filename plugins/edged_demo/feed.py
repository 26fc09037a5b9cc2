"""The dashboard's view of the pipeline: the newest estimate of each estimator and the
newest health snapshot, taken from the runtime's router like any output takes them.

Why the router and not the estimators: an estimator may run in a process of its own
(the draft one does), and what the dashboard shows must be what Zenoh and the
recording get, stale flags included. Why not `Runtime.health_snapshot()`: each call
restarts the rates' interval, so a second reader would halve the rates the published
snapshot carries; the 1 Hz snapshot the runtime already publishes is read instead.

The subscription's queue is bounded and only its newest records matter: the
dashboard drains it at each refresh. An overflow (a refresh that never came) drops
records for this subscriber only, counted in the router's stats, never blocking.
"""

from __future__ import annotations

from typing import Any, Iterable

from edged.estimates import estimate_to_json
from edged.records import Estimate, HealthRecord
from edged.router import Router, Subscription

#: Subscriber name in the router's stats (`info.queues`).
NAME = "demo:dashboard"
#: About a minute of the demo's estimates and health snapshots.
MAXSIZE = 1024


class LatestFeed:
    """Keeps the newest estimate per estimator instance and the newest health snapshot."""

    def __init__(self, router: Router, estimators: Iterable[str], maxsize: int = MAXSIZE) -> None:
        self._router = router
        keys = ["health", *(f"est/{name}" for name in estimators)]
        self.sub: Subscription = router.subscribe(NAME, keys, maxsize=maxsize, preferred_only=False)
        self._estimates: dict[str, Estimate] = {}
        self._health: dict[str, Any] | None = None

    def update(self) -> int:
        """Take what the router queued since the last call; returns how many records."""
        batch = self.sub.queue.drain_nowait()
        for rec in batch:
            if isinstance(rec, Estimate):
                self._estimates[rec.name] = rec
            elif isinstance(rec, HealthRecord):
                self._health = rec.values
        return len(batch)

    def snapshot(self) -> dict[str, Any]:
        """`{"estimates": {name: payload as published}, "health": snapshot or None}`:
        what `dashboard.render` reads (the payloads are fresh dicts; the health snapshot
        is the one the outputs got, not to be changed)."""
        return {
            "estimates": {name: estimate_to_json(e) for name, e in self._estimates.items()},
            "health": self._health,
        }

    def close(self) -> None:
        self._router.unsubscribe(self.sub)
