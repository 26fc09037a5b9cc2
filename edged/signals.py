"""Stop signals that are honoured even while a core's step holds the event loop.

The daemon and `edged replay` take SIGTERM and SIGINT through the event loop
(`loop.add_signal_handler`): the stop then runs as a coroutine, inputs first, queues
drained, outputs closed. An estimator core placed in the loop runs synchronously, so a
step that does not return (a filter integrating across a month, a bug) left the loop
deaf: a replay went on for ten minutes after SIGTERM (issue 30).

`StopSignals` keeps the loop's handler and adds a Python-level one beside it, which
runs in the main thread between two bytecodes whatever the loop is doing. Once a stop
was asked for, a watcher thread checks every `timeout / 4` seconds whether a core step
(`step()`, entered by the loop's runner around each batch) has run for more than
`timeout / 2`; if so it signals the main thread again, and the handler raises
`StopRequested` inside that step. The runner reports it as the core's failure (its
batch is counted lost), and the loop goes on with the stop, within `shutdown_timeout`.
A step that returns in time is never interrupted: what was queued is still processed.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
import threading
import time
from contextlib import contextmanager
from typing import Callable, Iterator

log = logging.getLogger("edged.signals")

#: What stops the daemon and a replay: systemd's stop, a terminal's Ctrl-C and Ctrl-\\
#: (SIGQUIT: a graceful quit, as nginx reads it, not a core dump that loses the file).
STOP = (signal.SIGTERM, signal.SIGINT, signal.SIGQUIT)
#: Signals that mean nothing here and whose default would end the process, leaving a
#: recording unfinished: logged and ignored.
IGNORED = (signal.SIGUSR1, signal.SIGUSR2)

#: When the step that now runs in the main thread began (time.monotonic()), or None.
_step_since: float | None = None


class StopRequested(BaseException):
    """Raised inside a core step that held the event loop too long after a stop signal
    (a BaseException, like KeyboardInterrupt: a core's `except Exception` keeps it not)."""


@contextmanager
def step() -> Iterator[None]:
    """Mark a synchronous core step in the event loop's thread (the watcher times it)."""
    global _step_since
    outer = _step_since
    _step_since = time.monotonic()
    try:
        yield
    finally:
        _step_since = outer


class StopSignals:
    """The `STOP` signals to `on_signal(sig)` through the loop, and to a step that holds
    the loop past half of `timeout` after the first of them; `IGNORED` logged.

    `hangup_stops`: SIGHUP stops as well (a replay: the terminal it ran in closed),
    unless the process was started with SIGHUP ignored (`nohup`). The daemon gives
    SIGHUP its own meaning (logs reopened, files rotated)."""

    def __init__(self, loop: asyncio.AbstractEventLoop, on_signal: Callable[[signal.Signals], None],
                 timeout: float, *, hangup_stops: bool = False) -> None:
        self.loop = loop
        self.on_signal = on_signal
        self.timeout = timeout
        sigs = list(STOP)
        if hangup_stops and signal.getsignal(signal.SIGHUP) is not signal.SIG_IGN:
            sigs.append(signal.SIGHUP)
        self.signals = tuple(sigs)
        self.installed: list[signal.Signals] = []
        self._ignoring: list[signal.Signals] = []
        self._asked: signal.Signals | None = None
        self._overdue = False
        self._done = threading.Event()
        self._watcher: threading.Thread | None = None
        self._main = threading.main_thread().ident

    def install(self) -> "StopSignals":
        for sig in IGNORED:
            try:
                self.loop.add_signal_handler(sig, _ignored, sig)
            except (NotImplementedError, RuntimeError, ValueError):  # not the main thread
                continue
            self._ignoring.append(sig)
        for sig in self.signals:
            try:
                self.loop.add_signal_handler(sig, self.on_signal, sig)
            except (NotImplementedError, RuntimeError, ValueError):  # not the main thread
                continue
            # The loop's own handler only wakes the loop; ours runs in the main thread at
            # once, even when the loop is held (the loop still hears the signal itself
            # through its wakeup fd and calls on_signal).
            signal.signal(sig, self._handler)
            self.installed.append(sig)
        return self

    def remove(self) -> None:
        self._done.set()
        for sig in (*self.installed, *self._ignoring):
            self.loop.remove_signal_handler(sig)
        self.installed.clear()
        self._ignoring.clear()

    def _handler(self, signum: int, frame: object) -> None:
        if self._asked is None:
            self._asked = signal.Signals(signum)
            self._watcher = threading.Thread(target=self._watch, name="edged-stop-watch", daemon=True)
            self._watcher.start()
        if self._overdue and _step_since is not None:
            self._overdue = False
            raise StopRequested(f"{self._asked.name}: a core step held the event loop for more than "
                                f"{self.timeout / 2:g} s (half of shutdown_timeout)")

    def _watch(self) -> None:
        limit = self.timeout / 2.0
        while not self._done.wait(self.timeout / 4.0):
            since = _step_since
            if since is not None and time.monotonic() - since > limit and self._main is not None:
                self._overdue = True
                assert self._asked is not None
                signal.pthread_kill(self._main, self._asked)


def _ignored(sig: signal.Signals) -> None:
    log.warning("event=signal-ignored signal=%s reason='it means nothing to edged'", sig.name)


#: The signals a process of the daemon's own (a recorder, a worker) leaves to the parent.
CHILD_IGNORES = (*STOP, signal.SIGHUP, *IGNORED)


def ignore_stop_signals() -> None:
    """In a child process: ignore the stop signals that reach the whole process group.

    Ctrl-C in a terminal, a hangup, and `systemctl stop` (systemd's default
    KillMode=control-group sends SIGTERM to every process of the service) reach the
    children too; a recorder that died of it left its MCAP unfinished while the daemon
    still exited 0 (issue 32). The parent decides when a child ends: it drains the child
    and tells it to stop, and a child whose parent is gone ends by itself (its pipe
    closes). Only SIGKILL, systemd's last word after TimeoutStopSec, ends it otherwise."""
    for sig in CHILD_IGNORES:
        signal.signal(sig, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, CHILD_IGNORES)  # (blocked from birth: see `blocked_in_children`)


@contextlib.contextmanager
def blocked_in_children() -> Iterator[None]:
    """Around the start of a child process: the stop signals blocked in the thread that
    starts it, so that the child is born with them blocked (a signal mask survives
    fork and exec) until `ignore_stop_signals` ignores them. A replay reads while its
    children import their stack (issue 34): Ctrl-C to the process group in that second
    would otherwise kill a recorder before it could ignore it. The parent misses
    nothing: a signal meanwhile is taken by another of its threads, or waits until the
    mask is restored."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, CHILD_IGNORES)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
