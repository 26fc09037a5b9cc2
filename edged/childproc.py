"""The process host: whatever runs in a child process of its own, an estimator's core
(`worker = "process"` in its table) or an output plugin, is started, called, watched
and ended here, one way for both.

Why a process: a heavy filter or a recorder's work (JSON, MCAP chunks, compression,
fsync) then uses another core and stalls only itself, never the event loop.

A call is pickled in the event loop (pickling needs the GIL wherever it is done; a
helper thread doing it would only contend for it), its bytes go out through a writer
thread (a pipe the child has not emptied yet must not hold the loop), and a receiver
thread takes the answers, which come in the order of the calls, and hands each to the
loop: there the answer's log records are re-emitted, its report given to the owner
(`on_report`) and the call's future resolved. The protocol and the child's loop are
`edged.childmain`'s.

The receiver is also the watchdog: a call not answered within its limit (`watchdog`
seconds after it was sent or after the answer before it, whichever is later) means a
hung child, which is killed; its end of the pipe then ends every call still waiting
with `ChildDied`, as any other death does (a crash, a kill from outside). A call made
when the child is gone fails at once with `ChildGone`: the receiver marks the death
under the same lock with which a call is queued, so that no call ever waits behind a
child that is gone.
"""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import os
import pickle
import signal
import threading
import time
import weakref
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from multiprocessing import resource_tracker
from multiprocessing.reduction import ForkingPickler
from typing import Any, Callable

from .childmain import CallFailed, Servant, serve
from .signals import blocked_in_children

__all__ = ["ChildProcess", "ChildDied", "ChildGone", "CallFailed", "forget", "sigkill", "START_TIMEOUT", "WATCHED"]

#: Seconds a child may take to import its stack and make its servant (numpy and a
#: filter stack take a while on a small gateway).
START_TIMEOUT = 60.0
#: Seconds a child told to stop may take to end before it is killed.
STOP_WAIT = 5.0
#: A call's limit: the owner's `watchdog`.
WATCHED = -1.0

Answer = tuple[Any, ...]


class ChildDied(RuntimeError):
    """The child is gone (killed, crashed, hung and killed): its calls are lost."""


class ChildGone(ChildDied):
    """A call made when the child was already gone (not started, stopped or dead)."""


class _Call:
    """A call on its way: its future, its limit in seconds (None: not watched) and
    when it was sent."""

    __slots__ = ("future", "limit", "sent")

    def __init__(self, future: "asyncio.Future[Any]", limit: float | None, sent: float) -> None:
        self.future = future
        self.limit = limit
        self.sent = sent


class _Link:
    """One child's pipe, as its receiver last saw it: the calls waiting for an answer,
    when the last answer came, and why it ended when the watchdog ended it."""

    __slots__ = ("dead", "pending", "answered", "why")

    def __init__(self, dead: bool) -> None:
        self.dead = dead
        self.pending: deque[_Call] = deque()
        self.answered = 0.0
        self.why: str | None = None


class ChildProcess:
    """One child at a time for one owner (a worker's core, an output), started again
    after each failure. `make` is the top-level function that makes the servant in the
    child (`make(clock, *args)`), `clock` what every call carries the time of, and
    `on_report` takes each answer's report, in the loop, in the order of the calls."""

    def __init__(self, name: str, make: Callable[..., Servant], clock: Any, watchdog: float,
                 on_report: Callable[[Any], None]) -> None:
        self.name = name
        self.make = make
        self.clock = clock
        self.watchdog = watchdog
        self.on_report = on_report
        self.process: Any = None
        self._conn: Any = None
        self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"edged-{name}-send")
        self._lock = threading.Lock()
        self._link = _Link(dead=True)
        self._loop: asyncio.AbstractEventLoop | None = None
        self.log = logging.getLogger("edged.childproc")

    @property
    def pid(self) -> int | None:
        return None if self.process is None else self.process.pid

    @property
    def alive(self) -> bool:
        """Started, not stopped, and still running (not while a thread waits for it to
        end: the receiver after its pipe ended, or the stop)."""
        p = self.process
        if p is None:
            return False
        lock = _waiting(p)
        if not lock.acquire(blocking=False):
            return False
        try:
            return p.is_alive()
        finally:
            lock.release()

    @property
    def pending(self) -> deque[_Call]:
        """The calls on their way to the current child, oldest first."""
        return self._link.pending

    # -- start -------------------------------------------------------------------------
    async def start(self, args: tuple[Any, ...], role: str) -> None:
        """Start a child and wait until its servant is made; raises `ChildDied` when it
        died or did not answer in time, RuntimeError when the servant could not be
        made (the child's message)."""
        await self.launch(args, role)

    def launch(self, args: tuple[Any, ...], role: str) -> "asyncio.Future[None]":
        """Start a child without waiting for it: calls submitted from now on queue
        behind its start (the child takes them once its servant is made), so that an
        owner goes on at once, as in the loop (a replay reads its first records while
        the child imports its stack: issue 34's start-up). The future is done when the
        servant is made; it fails as `start` raises, and so does every call queued
        behind a start that failed. The process is started here, in the loop (a few
        milliseconds: the interpreter's own start is the child's)."""
        self._loop = loop = asyncio.get_running_loop()
        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe(duplex=True)
        p = ctx.Process(target=serve, args=(child, self.make, args, logging.getLogger().getEffectiveLevel()),
                        name=f"edged-{self.name}", daemon=True)
        # (multiprocessing's resource tracker, started at the first child, unblocks
        # SIGINT and SIGTERM in the thread that starts it: it is started before)
        resource_tracker.ensure_running()
        with blocked_in_children():
            p.start()
        child.close()
        hello: asyncio.Future[None] = loop.create_future()
        self.process, self._conn = p, parent
        self._link = link = _Link(dead=False)
        threading.Thread(target=self._receive, args=(parent, p, link, (hello, role)),
                         name=f"edged-{self.name}-recv", daemon=True).start()
        return hello

    def _hello(self, conn: Any, p: Any, link: _Link) -> Answer | None:
        """(the receiver thread) The child's first answer, its servant made or not;
        None when it died or did not answer in time (`link.why` says which)."""
        timeout = max(self.watchdog, START_TIMEOUT)
        try:
            if conn.poll(timeout):
                return conn.recv()  # type: ignore[no-any-return]
            link.why = f"watchdog: {self.name}'s process did not start within {timeout:g} s; killed"
            sigkill(p)
        except (EOFError, OSError):
            _join(p, 1.0)
            link.why = f"{self.name}'s process died while starting (exit code {p.exitcode})"
        return None

    def _started(self, fut: "asyncio.Future[None]", answer: Answer | None, why: str | None, role: str,
                 pid: int | None) -> None:
        """(in the loop) The start's outcome onto its future."""
        if answer is not None:
            self._emit(answer[-1])
        if fut.done():
            return
        if answer is None:
            fut.set_exception(ChildDied(why or f"{self.name}'s process died while starting"))
        elif answer[0] != "ok":
            fut.set_exception(RuntimeError(f"could not be made in its process: {answer[1]}"))
        else:
            self.on_report(answer[2])
            self.log.info("%s=%s placement=process pid=%s", role, self.name, pid)
            fut.set_result(None)

    # -- calls -------------------------------------------------------------------------
    def submit(self, what: str, arg: Any = None, *, now: float | None = None, mono: float | None = None,
               limit: float | None = WATCHED) -> "asyncio.Future[Any]":
        """The call on its way behind those before it (with the clock as it reads now,
        or `now`, `mono`); its future has the call's value, or raises `CallFailed`,
        `ChildDied` or (the child was gone before) `ChildGone`. `limit`: seconds the
        answer may take (default the watchdog; None: not watched)."""
        loop = self._loop or asyncio.get_running_loop()
        fut: asyncio.Future[Any] = loop.create_future()
        link, conn = self._link, self._conn
        if conn is None or link.dead:
            fut.set_exception(self._gone(link))
            return fut
        if now is None or mono is None:
            now, mono = self.clock.now(), self.clock.monotonic()
        data = ForkingPickler.dumps((what, now, mono, arg), pickle.HIGHEST_PROTOCOL)
        call = _Call(fut, self.watchdog if limit == WATCHED else limit, time.monotonic())
        with self._lock:
            if link.dead:  # the receiver saw the end of the pipe meanwhile
                fut.set_exception(self._gone(link))
                return fut
            link.pending.append(call)
        self._writer.submit(_send, conn, data)
        return fut

    def _gone(self, link: _Link) -> "ChildGone":
        """A call refused: the process was gone before it was sent (and why, once the
        receiver knows: a kill's exit code is what an operator looks for)."""
        return ChildGone(f"{self.name}'s process is gone" + (f": {link.why}" if link.why else ""))

    def _receive(self, conn: Any, p: Any, link: _Link, start: tuple["asyncio.Future[None]", str]) -> None:
        """(the receiver thread) The start's answer; then answers onto their calls, in
        order; the watchdog; at the end of the pipe (or after a start that failed),
        every call still waiting fails."""
        loop = self._loop
        assert loop is not None
        pending = link.pending
        hello = self._hello(conn, p, link)
        ok = hello is not None and hello[0] == "ok"
        if hello is not None and not ok:
            link.why = f"{self.name} could not be made in its process: {hello[1]}"
        _to_loop(loop, self._started, start[0], hello, link.why, start[1], p.pid)
        with self._lock:
            link.answered = time.monotonic()  # the calls queued behind the start are due from now
        while ok:
            try:
                if not conn.poll(self._wait(link)):
                    self._watch(link, p)
                    continue
                answer = conn.recv()
            except (EOFError, OSError):
                break
            with self._lock:
                call = pending.popleft()
                link.answered = time.monotonic()
            _to_loop(loop, self._answered, call.future, answer)
        _join(p, 1.0)
        why = ChildDied(link.why or f"{self.name}'s process died (exit code {p.exitcode})")
        with self._lock:  # no call is queued behind this: it would wait for ever
            link.why = str(why)  # what a call made from now on is refused with
            link.dead = True
            left = [c.future for c in pending]
            pending.clear()
        try:
            conn.close()
        except OSError:
            pass
        _to_loop(loop, _fail, left, why)

    def _wait(self, link: _Link) -> float:
        """Seconds until the oldest call is due (the watchdog itself when none waits:
        a call sent meanwhile is then looked at in time)."""
        with self._lock:
            oldest = link.pending[0] if link.pending else None
            answered = link.answered
        if oldest is None or oldest.limit is None or link.why is not None:
            return self.watchdog  # (killed by the watchdog: the end of the pipe follows)
        return max(0.0, max(oldest.sent, answered) + oldest.limit - time.monotonic())

    def _watch(self, link: _Link, p: Any) -> None:
        """No answer came in time: when the oldest call is overdue, the child is hung
        and goes (its end of the pipe then ends the receiver's loop)."""
        with self._lock:
            oldest = link.pending[0] if link.pending else None
            answered = link.answered
        if oldest is None or oldest.limit is None or link.why is not None:
            return
        if time.monotonic() - max(oldest.sent, answered) >= oldest.limit:
            link.why = f"watchdog: no answer from {self.name}'s process within {oldest.limit:g} s; killed"
            sigkill(p)

    def _answered(self, fut: "asyncio.Future[Any]", answer: Answer) -> None:
        """(in the loop) One answer: its log, its report, then its call's future."""
        self._emit(answer[-1])
        if answer[0] == "ok":
            self.on_report(answer[2])
            if not fut.done():
                fut.set_result(answer[1])
            return
        self.on_report(answer[3])
        if not fut.done():
            fut.set_exception(CallFailed(answer[1], answer[2]))

    @staticmethod
    def _emit(logs: list[tuple[str, int, str]]) -> None:
        for name, level, text in logs:
            logging.getLogger(name).log(level, "%s", text)

    # -- end ---------------------------------------------------------------------------
    async def stop(self) -> None:
        """Tell the child to stop (behind everything sent before), wait for it, and kill
        it when it does not end in time."""
        p, conn = self.process, self._conn
        self.process = self._conn = None
        if p is not None:
            stop = ForkingPickler.dumps(("stop", 0.0, 0.0, None), pickle.HIGHEST_PROTOCOL)
            await asyncio.get_running_loop().run_in_executor(None, self._end, p, conn, stop)

    def _end(self, p: Any, conn: Any, stop: bytes) -> None:
        end = time.monotonic() + STOP_WAIT
        try:  # (a hung child's full pipe must not hold the stop: it is killed instead)
            self._writer.submit(_send, conn, stop).result(STOP_WAIT)
        except TimeoutError:
            pass
        _join(p, max(0.0, end - time.monotonic()))
        _reap(p, None)

    def kill_now(self) -> None:
        """From the event loop, when a call did not end in time at shutdown: the child
        goes at once (without waiting for it)."""
        sigkill(self.process)

    def close(self) -> None:
        """Last words at shutdown: a child still there is killed, the writer goes."""
        p, self.process, self._conn = self.process, None, None
        if p is not None:
            _reap(p, None)
        self._writer.shutdown(wait=False)


def _send(conn: Any, data: bytes) -> None:
    try:
        conn.send_bytes(data)
    except (OSError, ValueError):
        pass  # the child is gone: the receiver sees the end of the pipe and says so


def _to_loop(loop: asyncio.AbstractEventLoop, fn: Callable[..., None], *args: Any) -> None:
    try:
        loop.call_soon_threadsafe(fn, *args)
    except RuntimeError:  # the loop is closed: nobody waits for the answer any more
        pass


def forget(fut: "asyncio.Future[Any]") -> None:
    """Nobody awaits this call's outcome (a flush, a call after one that failed): its
    exception, if any, is taken, not reported as never retrieved."""
    fut.add_done_callback(lambda f: f.cancelled() or f.exception())


def _fail(futures: list["asyncio.Future[Any]"], why: ChildDied) -> None:
    for fut in futures:
        if not fut.done():
            fut.set_exception(why)


def sigkill(p: Any) -> None:
    """SIGKILL a child process at once, if it is there (without waiting for it)."""
    if p is not None and p.pid is not None:
        try:
            os.kill(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def _reap(p: Any, conn: Any) -> None:
    """The one way a child ends for good: killed if still alive, waited for; its pipe
    closed when no receiver owns it (the receiver closes its own at the end)."""
    with _waiting(p):
        if p.is_alive():
            sigkill(p)
        p.join(STOP_WAIT)
    if conn is not None:
        try:
            conn.close()
        except OSError:
            pass


#: One lock per child process around every wait for it (`join`, `is_alive`): the
#: receiver thread, the stop and the loop may look at one child at once, and
#: multiprocessing's wait is not thread-safe (the loser of two `waitpid`s sees a live
#: child with no exit code, and could signal a pid already reaped).
_WAIT_LOCKS: "weakref.WeakKeyDictionary[Any, threading.Lock]" = weakref.WeakKeyDictionary()
_WAIT_LOCKS_GUARD = threading.Lock()


def _waiting(p: Any) -> threading.Lock:
    with _WAIT_LOCKS_GUARD:
        lock = _WAIT_LOCKS.get(p)
        if lock is None:
            lock = _WAIT_LOCKS[p] = threading.Lock()
        return lock


def _join(p: Any, timeout: float) -> None:
    """Wait up to `timeout` s for a child to end, alone."""
    with _waiting(p):
        p.join(timeout)
