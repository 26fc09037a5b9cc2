"""Supervision: run a plugin's coroutine, restart it with exponential backoff on failure.

A plugin that raises is reported in health (state `backoff`, last error, restart
count) and started again after 1, 2, 4 … seconds up to a ceiling; the backoff resets
once the plugin has run for `stable_after` seconds. The other plugins never notice.
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass
from typing import Awaitable, Callable

from .backoff import Backoff
from .clock import Clock
from .health import ComponentHealth

log = logging.getLogger("edged.supervisor")

Sleep = Callable[[float], Awaitable[None]]


@dataclass(frozen=True)
class RestartPolicy:
    initial: float = 1.0
    factor: float = 2.0
    maximum: float = 60.0
    #: Seconds a run must last for the next failure to start again from `initial`.
    stable_after: float = 60.0

    def backoff(self) -> Backoff:
        return Backoff(self.initial, self.maximum, self.factor)


async def supervise(
    run: Callable[[], Awaitable[None]],
    health: ComponentHealth,
    clock: Clock,
    *,
    policy: RestartPolicy = RestartPolicy(),
    sleep: Sleep = asyncio.sleep,
    on_restart: Callable[[], Awaitable[None]] | None = None,
) -> None:
    """Run `run()` until it returns or is cancelled; restart it when it raises.

    `on_restart` is awaited before each restart (an output closes itself there).
    Cancellation propagates: that is how the runtime stops a plugin.
    """
    backoff = policy.backoff()
    while True:
        started = clock.monotonic()
        health.set_state("running")
        try:
            await run()
        except asyncio.CancelledError:
            health.set_state("stopped")
            raise
        except Exception as exc:  # a plugin's failure must never reach the others
            if clock.monotonic() - started >= policy.stable_after:
                backoff.reset()
            delay = backoff.next_delay()
            health.error(f"{type(exc).__name__}: {exc}")
            log.debug("component=%s traceback", health.name, exc_info=True)
            health.restarts += 1
            health.info["next_restart_in"] = delay
            health.set_state("backoff", f"restart {health.restarts} in {delay:g} s")
            if on_restart is not None:
                try:
                    await on_restart()
                except Exception as exc2:
                    health.error(f"cleanup: {type(exc2).__name__}: {exc2}")
            await sleep(delay)
            health.info.pop("next_restart_in", None)
            continue
        health.set_state("finished")
        return
