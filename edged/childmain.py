"""The child's side of the process host (`edged.childproc`): one loop for every child.

A child runs one *servant*: an estimator's core (`edged.workerproc`) or an output
plugin (`edged.outputproc`), made here by a top-level function of its module from
picklable arguments (the plugin's class and configuration), so that neither the core
nor the plugin itself need be picklable. The child is started with multiprocessing's
"spawn" method: a fresh interpreter, no copy of the daemon's threads, sockets or
zenoh session.

Messages (parent -> child): `(what, now, mono, arg)`, the parent clock's `now()` and
`monotonic()` as the parent read them for this call, which the child's clock then
reads (`MirroredClock`): a plugin sees the same time at the same record as it would in
the event loop, live and in replay. `("stop", ...)` ends the child.

Answers (child -> parent), one per message and in their order:
`("ok", value, report, logs)` or `("error", message, value, report, logs)`. `value` of
an error is what the call did before it failed (an estimator's results so far);
`report` is the servant's `report()`; `logs` the log records the child made since the
last answer (name, level, text), which the parent re-emits under their own logger
names. The first answer, before any message, says whether the servant could be made.
"""

from __future__ import annotations

import logging
from multiprocessing.connection import Connection
from typing import Any, Callable, Protocol

from .signals import ignore_stop_signals

__all__ = ["serve", "MirroredClock", "CallFailed", "Servant"]


class CallFailed(Exception):
    """A call the servant raised on (the child goes on): its message, and what the call
    did before it failed (`value`)."""

    def __init__(self, message: str, value: Any = None) -> None:
        super().__init__(message)
        self.message = message
        self.value = value


class Servant(Protocol):
    """What a child runs: one call at a time, and a report sent with every answer."""

    def call(self, what: str, arg: Any) -> Any: ...

    def report(self) -> Any: ...


class MirroredClock:
    """The parent's clock as it read when the current message was sent."""

    __slots__ = ("_now", "_mono")

    def __init__(self, now: float = 0.0, mono: float = 0.0) -> None:
        self._now = now
        self._mono = mono

    def set(self, now: float, mono: float) -> None:
        self._now = now
        self._mono = mono

    def now(self) -> float:
        return self._now

    def monotonic(self) -> float:
        return self._mono


class _Collect(logging.Handler):
    """Keeps the child's log records until the next answer takes them to the parent."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[tuple[str, int, str]] = []

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = record.getMessage()
            if record.exc_info:  # `log.exception` in a core or a plugin: its traceback too
                text += "\n" + logging.Formatter().formatException(record.exc_info)
        except Exception:  # a record that cannot be formatted must not stop the child
            text = str(record.msg)
        self.records.append((record.name, record.levelno, text))

    def take(self) -> list[tuple[str, int, str]]:
        out, self.records = self.records, []
        return out


def _error(exc: Exception) -> tuple[str, Any]:
    if isinstance(exc, CallFailed):
        return exc.message, exc.value
    return f"{type(exc).__name__}: {exc}", None


def serve(conn: Connection, make: Callable[..., Servant], args: tuple[Any, ...], level: int) -> None:
    """The child's main loop: `make(clock, *args)` is its servant. Returns when told to
    stop or when the parent is gone (its end of the pipe closes)."""
    ignore_stop_signals()
    logs = _Collect()
    root = logging.getLogger()
    root.handlers[:] = [logs]
    root.setLevel(level)
    clock = MirroredClock()
    try:
        servant = make(clock, *args)
    except Exception as exc:
        conn.send(("error", _error(exc)[0], None, None, logs.take()))
        return
    conn.send(("ok", None, servant.report(), logs.take()))
    while True:
        try:
            what, now, mono, arg = conn.recv()
        except (EOFError, OSError):  # the parent died or closed the pipe
            return
        if what == "stop":
            return
        clock.set(now, mono)
        try:
            value = servant.call(what, arg)
        except Exception as exc:
            message, partial = _error(exc)
            conn.send(("error", message, partial, servant.report(), logs.take()))
            continue
        conn.send(("ok", value, servant.report(), logs.take()))
