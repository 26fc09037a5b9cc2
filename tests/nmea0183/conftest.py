"""Helpers for the NMEA 0183 input tests (fixtures; tests import nothing from here)."""

from __future__ import annotations

import asyncio
from functools import reduce
from operator import xor
from pathlib import Path
from typing import Callable

import pytest

from edged.clock import ManualClock
from edged.health import ComponentHealth

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "nmea0183"


def _nmea(body: str, start: str = "$") -> str:
    return "%s%s*%02X" % (start, body, reduce(xor, body.encode(), 0))


class EventHealth(ComponentHealth):
    """ComponentHealth whose state changes can be awaited (no sleep-polling in tests)."""

    __slots__ = ("_changed", "history")

    def __init__(self) -> None:
        super().__init__("gnss1", "input", "nmea0183", ManualClock(1_700_000_000.0))
        self._changed: asyncio.Condition | None = None
        self.history: list[str] = []

    def set_state(self, state: str, reason: str | None = None) -> None:
        super().set_state(state, reason)
        self.history.append(state)
        if self._changed is not None:
            self._notify()

    def _notify(self) -> None:
        cond = self._changed

        async def wake() -> None:
            async with cond:  # type: ignore[union-attr]
                cond.notify_all()  # type: ignore[union-attr]

        asyncio.get_running_loop().create_task(wake())

    async def wait_for(self, pred: Callable[[], bool], timeout: float = 10.0) -> None:
        """Wait until `pred()` holds, woken by state changes (timeout: a safety net)."""
        if self._changed is None:
            self._changed = asyncio.Condition()
        async with self._changed:
            await asyncio.wait_for(self._changed.wait_for(pred), timeout)

    async def wait_state(self, state: str, times: int = 1, timeout: float = 10.0) -> None:
        await self.wait_for(lambda: self.history.count(state) >= times, timeout)


@pytest.fixture
def nmea() -> Callable[..., str]:
    """`nmea("GPHDT,123.4,T")` -> the sentence with `$` and a correct checksum."""
    return _nmea


@pytest.fixture
def health() -> ComponentHealth:
    return ComponentHealth("gnss1", "input", "nmea0183", ManualClock(1_700_000_000.0))


@pytest.fixture
def event_health() -> EventHealth:
    return EventHealth()


@pytest.fixture
def data_dir() -> Path:
    if not DATA.is_dir():
        pytest.skip(f"../shared data not here: {DATA} not found")
    return DATA
