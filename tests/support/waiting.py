"""Waiting in a test for something another task or process does, bounded."""

from __future__ import annotations

import asyncio
from typing import Callable

SAFETY = 60.0  # seconds: only a broken worker or output ever waits this long


async def wait_for(cond: Callable[[], bool], timeout: float = SAFETY) -> None:
    """Until `cond()` holds; AssertionError after `timeout` seconds."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not cond():
        if loop.time() > end:
            raise AssertionError("condition not reached")
        await asyncio.sleep(0.001)
