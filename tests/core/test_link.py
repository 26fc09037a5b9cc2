"""edged.link: the one reconnect loop and link states every input shares.

A scripted link: each connection attempt takes the next step of a script (`Fail(exc)`:
the open raises exc; anything else: what the connection's session does).
The sleep is injected, so the backoff's delays are seen without being waited out.
"""

from __future__ import annotations

import asyncio
from typing import Any, Callable

import pytest

from edged.backoff import Backoff
from edged.clock import ManualClock
from edged.config import ReconnectSettings
from edged.health import OK_STATES, ComponentHealth
from edged.link import Link, LinkLost, LinkStale, LinkState

TIMEOUT = 5.0  # a safety net only


class Recorder(ComponentHealth):
    """ComponentHealth that remembers every state it was set to."""

    __slots__ = ("history",)

    def __init__(self) -> None:
        super().__init__("gnss1", "input", "test", ManualClock(1_700_000_000.0))
        self.history: list[str] = []

    def set_state(self, state: str, reason: str | None = None) -> None:
        super().set_state(state, reason)
        self.history.append(state)


class Fail:
    def __init__(self, exc: BaseException) -> None:
        self.exc = exc


class Script:
    """Opener, session and close of a fake link driven by a list of steps.

    A step is `Fail(exc)` (the open raises exc) or a session action: an exception
    the session raises, "ok" (return: a finite source ended), "stable" (call
    `link.stable()` then lose the link) or "hang" (wait until cancelled).
    """

    def __init__(self, health: Recorder, steps: list[Any], backoff: Backoff | None = None, **kw: Any) -> None:
        self.steps = list(steps)
        self.delays: list[float] = []
        self.states_in_sleep: list[str] = []
        self.info_in_sleep: list[Any] = []
        self.closed: list[int] = []
        self.opened = 0
        self.hanging = asyncio.Event()
        self.health = health
        self.link: Link[int] = Link(
            health, backoff or Backoff(0.5, 4.0), where="test 1", sleep=self._sleep, **kw
        )

    async def _sleep(self, delay: float) -> None:
        self.delays.append(delay)
        self.states_in_sleep.append(self.health.state)
        self.info_in_sleep.append(self.health.info.get("reconnect_in"))
        if not self.steps:
            await asyncio.Event().wait()  # script done: wait to be cancelled
        await asyncio.sleep(0)

    async def opener(self) -> int:
        step = self.steps.pop(0)
        if isinstance(step, Fail):
            raise step.exc
        self.opened += 1
        self._current = step
        return self.opened

    async def session(self, conn: int) -> None:
        step = self._current
        if step == "ok":
            return
        if step == "stable":
            self.link.stable()
            raise LinkLost("closed by the peer")
        if step == "hang":
            self.hanging.set()
            await asyncio.Event().wait()
        raise step

    async def close(self, conn: int) -> None:
        self.closed.append(conn)

    async def run(self, until: Callable[[], bool] | None = None) -> None:
        """Run the link; with `until`, cancel it once that holds (or the script runs out)."""
        task = asyncio.create_task(self.link.run(self.opener, self.session, self.close))
        if until is None:
            await asyncio.wait_for(task, TIMEOUT)
            return
        async def cond() -> None:
            while not until():
                await asyncio.sleep(0)
        try:
            await asyncio.wait_for(cond(), TIMEOUT)
        finally:
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task


def test_the_vocabulary_and_which_states_are_ok():
    assert LinkState.ALL == {"connecting", "connected", "stale", "disconnected", "finished"}
    ok = {s for s in LinkState.ALL if s in OK_STATES}
    assert ok == {"connected", "finished"}  # reconnecting (connecting, stale, disconnected) is not ok


async def test_failed_opens_back_off_doubling_to_the_cap():
    h = Recorder()
    refused = ConnectionRefusedError(111, "Connection refused")
    s = Script(h, [Fail(refused)] * 6, Backoff(0.5, 3.0))
    await s.run(until=lambda: len(s.delays) >= 6)
    assert s.delays == [0.5, 1.0, 2.0, 3.0, 3.0, 3.0]
    assert h.counters == {"connect_failures": 6, "errors": 6}
    assert set(s.states_in_sleep) == {"disconnected"}
    assert s.info_in_sleep == s.delays  # info["reconnect_in"] while waiting ...
    assert "reconnect_in" not in h.info  # ... and not once cancelled
    assert h.last_error == "test 1: cannot open: Connection refused"
    assert h.history[:4] == ["connecting", "disconnected", "connecting", "disconnected"]
    assert h.snapshot()["ok"] is False


async def test_a_lost_connection_is_counted_and_reopened():
    h = Recorder()
    s = Script(h, ["hang"])
    task = asyncio.create_task(s.link.run(s.opener, s.session, s.close))
    await asyncio.wait_for(s.hanging.wait(), TIMEOUT)
    assert h.state == "connected" and h.snapshot()["ok"] is True
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task

    h = Recorder()
    s = Script(h, [LinkLost("closed by the peer"), OSError("EIO"), "hang"])
    await s.run(until=lambda: s.hanging.is_set())
    assert h.history == ["connecting", "connected", "disconnected"] * 2 + ["connecting", "connected"]
    assert h.counters == {"connects": 3, "disconnects": 2, "errors": 1}
    assert h.last_error == "test 1: link broke: EIO"  # a link error is recorded, a LinkLost is not
    assert s.closed == [1, 2, 3]  # the third closed when cancelled
    assert s.delays == [0.5, 1.0]  # no data arrived: the backoff kept growing


async def test_the_watchdog_is_stale_then_disconnected():
    h = Recorder()
    s = Script(h, [LinkStale("no data for 5 s"), LinkLost("bus-off", state="stale"), "hang"])
    await s.run(until=lambda: s.hanging.is_set())
    assert h.history[:4] == ["connecting", "connected", "stale", "disconnected"]
    assert h.counters["watchdog"] == 2 and h.counters["disconnects"] == 2
    assert set(s.states_in_sleep) == {"disconnected"}
    with pytest.raises(ValueError):
        LinkLost("x", state="connected")


async def test_a_stable_connection_resets_the_backoff():
    h = Recorder()
    lost = LinkLost("closed by the peer")
    s = Script(h, [lost, lost, lost, "stable", lost, lost, lost])
    await s.run(until=lambda: len(s.delays) >= 7)
    # 0.5, 1, 2 while nothing works; data arrived on the 4th connection: 0.5 again.
    assert s.delays == [0.5, 1.0, 2.0, 0.5, 1.0, 2.0, 4.0]


async def test_a_finite_source_that_ends_is_finished():
    h = Recorder()
    s = Script(h, [Fail(OSError("not yet")), "ok"])
    await s.run()  # returns by itself
    assert h.history == ["connecting", "disconnected", "connecting", "connected", "finished"]
    assert h.state in OK_STATES
    assert h.counters == {"connect_failures": 1, "connects": 1, "errors": 1}
    assert s.closed == [1]


async def test_cancellation_closes_and_counts_nothing():
    h = Recorder()
    s = Script(h, ["hang"])
    task = asyncio.create_task(s.link.run(s.opener, s.session, s.close))
    await asyncio.wait_for(s.hanging.wait(), TIMEOUT)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    assert s.closed == [1]
    assert h.counters == {"connects": 1}
    assert h.state == "connected"  # the runtime says `stopped`, not the link


async def test_other_errors_reach_the_supervisor():
    s = Script(Recorder(), [Fail(ValueError("bad interface name"))])
    with pytest.raises(ValueError):
        await s.run()  # not one of open_errors: not retried
    h = Recorder()
    s = Script(h, [RuntimeError("a bug")])
    with pytest.raises(RuntimeError):
        await s.run()
    assert s.closed == [1] and "disconnects" not in h.counters
    s = Script(Recorder(), [OSError("EIO")], link_errors=())  # a link without link errors
    with pytest.raises(OSError):
        await s.run()


async def test_info_key_reports_the_link_without_touching_the_state():
    h = Recorder()
    h.set_state("running")
    s = Script(h, [Fail(OSError("no router")), "hang"], info_key="zenoh")
    await s.run(until=lambda: s.hanging.is_set())
    assert h.history == ["running"]
    assert h.info["zenoh"] == "connected"
    assert h.counters == {"connect_failures": 1, "connects": 1, "errors": 1}


async def test_open_alone_retries_until_it_opens():
    h = Recorder()
    s = Script(h, [Fail(OSError("down")), Fail(OSError("down")), "hang"], ReconnectSettings().backoff())
    assert await asyncio.wait_for(s.link.open(s.opener), TIMEOUT) == 1
    assert s.delays == [0.5, 1.0]  # ReconnectSettings' defaults
    assert h.state == "connected" and h.counters["connects"] == 1
