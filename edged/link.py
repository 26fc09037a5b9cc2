"""Keeping a link open: one vocabulary of link states and one reconnect loop.

Every input that holds a connection (a serial port, a TCP multiplexer, a UDP socket,
a CAN bus, a zenoh session) reports it the same way in health, whatever the sensor:

    connecting -> connected -> stale (the watchdog fired) -> disconnected -> connecting ...
    connecting -> disconnected (the open failed) -> connecting ...
    connecting -> connected -> finished (a finite source, a file, read to its end)

`connected` and `finished` are in `edged.health.OK_STATES`; `connecting`, `stale` and
`disconnected` are not, so an input that is reconnecting reports `ok: false`. Why a
link went down (the peer closed, a bus-off, a bus error) is a *reason*: logged with the
state change and, when the component says so, its last error, never a state of its own.

Counters, the same for every link: `connects`, `connect_failures`, `disconnects` (an
established connection that ended, for whatever reason) and `watchdog`. While waiting
before the next attempt, `info["reconnect_in"]` holds the delay.

`Link.run` is the loop: open with exponential backoff (`edged.backoff.Backoff`, made
from `edged.config.ReconnectSettings`), run the component's session on the
connection, close it, wait, reopen. The session calls `Link.stable()` once the
connection has proven itself (data arrived): the next failure then waits the initial
delay again instead of the last, longest one.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any, Awaitable, Callable, Final, Generic, TypeVar

from .backoff import Backoff
from .health import ComponentHealth

__all__ = ["LinkState", "LinkLost", "LinkStale", "Link", "Sleep", "stop_task"]

Sleep = Callable[[float], Awaitable[Any]]
C = TypeVar("C")


class LinkState:
    """The states of a link (plain strings: they go into health as they are)."""

    CONNECTING: Final = "connecting"
    CONNECTED: Final = "connected"
    #: The link is open but silent for longer than its watchdog; it is closed next.
    STALE: Final = "stale"
    #: Closed (the open failed or the connection ended): waiting to reopen.
    DISCONNECTED: Final = "disconnected"
    #: A finite source read to its end; nothing is reopened.
    FINISHED: Final = "finished"

    ALL: Final = frozenset({CONNECTING, CONNECTED, STALE, DISCONNECTED, FINISHED})


class LinkLost(Exception):
    """Raised by a session: the connection ended and is to be reopened.

    The message is the reason (`"closed by the peer"`, `"bus-off"`); `state` is the
    state the link was in when it ended: `disconnected`, or `stale` for a watchdog.
    """

    state: str = LinkState.DISCONNECTED

    def __init__(self, reason: str = "", *, state: str | None = None) -> None:
        super().__init__(reason)
        if state is not None:
            if state not in (LinkState.DISCONNECTED, LinkState.STALE):
                raise ValueError(f"a lost link is disconnected or stale, not {state!r}")
            self.state = state


class LinkStale(LinkLost):
    """Raised by a session whose watchdog fired: no data for too long."""

    state = LinkState.STALE


def _why(exc: BaseException) -> object:
    return getattr(exc, "strerror", None) or exc


class Link(Generic[C]):
    """Opens a connection, runs a session on it and reopens it with backoff.

    `where` names the link in reasons and errors (`"tcp 10.0.0.5:10110"`).
    `open_errors` are the exceptions of a failed open (retried after the backoff);
    `link_errors` those that end an established connection (recorded as the last
    error, then reopened); anything else propagates to the supervisor.
    With `info_key`, the link state goes to `health.info[info_key]` instead of being
    the component's state: for a component whose state says something else (an output
    keeps recording whether or not its link is up).
    """

    def __init__(
        self,
        health: ComponentHealth,
        backoff: Backoff,
        *,
        where: str = "",
        sleep: Sleep = asyncio.sleep,
        open_errors: tuple[type[BaseException], ...] = (OSError,),
        link_errors: tuple[type[BaseException], ...] = (OSError,),
        info_key: str | None = None,
    ) -> None:
        self.health = health
        self.backoff = backoff
        self.where = where
        self.open_errors = open_errors
        self.link_errors = link_errors
        self.info_key = info_key
        self._sleep = sleep

    def stable(self) -> None:
        """The connection works (data arrived): the next failure waits the initial delay."""
        self.backoff.reset()

    def set_state(self, state: str, reason: str | None = None) -> None:
        if self.info_key is None:
            self.health.set_state(state, reason)
        else:
            self.health.info[self.info_key] = state

    async def _wait(self) -> None:
        delay = self.backoff.next_delay()
        info = self.health.info
        info["reconnect_in"] = delay
        try:
            await self._sleep(delay)
        finally:
            info.pop("reconnect_in", None)

    async def open(self, opener: Callable[[], Awaitable[C]]) -> C:
        """`await opener()` until it succeeds, waiting the backoff after each failure."""
        h = self.health
        where = self.where or None
        while True:
            self.set_state(LinkState.CONNECTING, where)
            try:
                conn = await opener()
            except self.open_errors as exc:
                h.count("connect_failures")
                h.error(f"{self.where}: cannot open: {_why(exc)}" if self.where else f"cannot open: {_why(exc)}")
                self.set_state(LinkState.DISCONNECTED, "open failed")
                await self._wait()
                continue
            h.count("connects")
            self.set_state(LinkState.CONNECTED, where)
            return conn

    async def run(
        self,
        opener: Callable[[], Awaitable[C]],
        session: Callable[[C], Awaitable[None]],
        close: Callable[[C], Awaitable[None]] | None = None,
    ) -> None:
        """Keep the link open until cancelled, or until `session` returns (`finished`).

        `session(conn)` runs while the connection is up; it ends the connection by
        raising `LinkLost`/`LinkStale` or one of `link_errors`, and returns only when
        a finite source is exhausted. `close(conn)` is awaited after every session,
        also when the task is cancelled (cancellation then propagates, nothing is
        counted).
        """
        h = self.health
        while True:
            conn = await self.open(opener)
            reason = self.where or None
            try:
                try:
                    await session(conn)
                finally:
                    if close is not None:
                        await close(conn)
            except LinkLost as exc:
                reason = str(exc) or reason
                if exc.state == LinkState.STALE:
                    h.count("watchdog")
                    self.set_state(LinkState.STALE, reason)
            except self.link_errors as exc:
                reason = f"link broke: {exc}"
                h.error(f"{self.where}: {reason}" if self.where else reason)
            else:
                self.set_state(LinkState.FINISHED, self.where or None)
                return
            h.count("disconnects")
            self.set_state(LinkState.DISCONNECTED, reason)
            await self._wait()


async def stop_task(task: "asyncio.Task[Any] | None") -> None:
    """Cancel a task that keeps a link (or any background task) and wait for its end,
    whatever it ended with: closing never raises for what the task did."""
    if task is None:
        return
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError, Exception):
        await task
