"""Exponential backoff between attempts: the one definition every reconnect uses.

A supervisor restarting a plugin, a serial or TCP link reconnecting, a CAN bus
reopening and a Zenoh session retrying all wait `initial`, then twice that, … up to
`maximum`, and start over once an attempt has worked (`reset`).
"""

from __future__ import annotations

import math


class Backoff:
    __slots__ = ("initial", "maximum", "factor", "_next")

    def __init__(self, initial: float = 1.0, maximum: float = 60.0, factor: float = 2.0) -> None:
        # Finite only: an infinite delay is a link that never retries (and nan compares
        # false with everything, so it would slip through the order checks below).
        if not all(isinstance(x, (int, float)) and math.isfinite(x) for x in (initial, maximum, factor)):
            raise ValueError(f"bad backoff: initial={initial}, maximum={maximum}, factor={factor} (must be finite)")
        if initial <= 0 or maximum < initial or factor < 1:
            raise ValueError(f"bad backoff: initial={initial}, maximum={maximum}, factor={factor}")
        self.initial = initial
        self.maximum = maximum
        self.factor = factor
        self._next = initial

    def next_delay(self) -> float:
        """The delay before the next attempt; each call makes the following one longer."""
        d = self._next
        self._next = min(d * self.factor, self.maximum)
        return d

    def reset(self) -> None:
        """The last attempt worked: the next failure waits `initial` again."""
        self._next = self.initial
