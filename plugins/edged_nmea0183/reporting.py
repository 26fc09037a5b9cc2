"""Logging of bad input once per kind of problem, never once per line (DESIGN §8).

A log of 100,000 sentences with an empty HDT field in each must say so once, not
100,000 times, even when other problems interleave (which defeats the last-message
check of ComponentHealth.error). Counting stays with the caller.
"""

from __future__ import annotations

from edged.health import ComponentHealth

MAX_DISTINCT = 256


class ProblemReporter:
    __slots__ = ("_health", "_seen")

    def __init__(self, health: ComponentHealth) -> None:
        self._health = health
        self._seen: set[str] = set()

    def report(self, message: str) -> None:
        """Record `message` as the component's error the first time it occurs."""
        if message in self._seen or len(self._seen) >= MAX_DISTINCT:
            return
        self._seen.add(message)
        self._health.error(message)
