"""An output in a process of its own (`worker = "process"` in its table).

Why: a recorder's work (JSON, MCAP chunks, compression, fsync) is as large as the
decoding itself in a fast replay, and a slow disk must never hold the event loop.
In a process of its own it uses the machine's second core and stalls only itself.

The parent (`ProcessOutput`, which the `OutputHost` uses in place of the plugin) starts
`serve` in a fresh interpreter (multiprocessing "spawn", as the process workers) and
sends it, in order (pickled in the loop, written by one thread, answered through another), the calls the plugin contract has:
`("open",)`, `("write", batch)`, `("flush",)`, `("rotate",)`, `("ready", timeout)`,
`("close",)`, `("stop",)`. Each message carries the parent clock's `now()` and
`monotonic()`, which the child's clock then reads (`MirroredClock`): the plugin sees
the same time at the same record as it would in the event loop, live and in replay.

Each answer is `("ok", value, report)` or `("error", message, report)`. The report
mirrors the child's health into the parent's component: counters (as increments),
state, last error, info; the log records the child made (re-emitted in the parent
under their own logger names); `status()`; and the plugin's `files` (what a recorder
has written), which the parent keeps and gives back to the next process after a
restart, so that a restarted recorder numbers its next file on instead of
overwriting the last.
"""

from __future__ import annotations

import asyncio
import logging
import os
import pickle
import signal
import threading
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from multiprocessing.reduction import ForkingPickler
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from .clock import Clock
from .health import ComponentHealth
from .signals import ignore_stop_signals

__all__ = ["ProcessOutput", "MirroredClock", "serve", "OutputProcessDied", "sigkill"]

log = logging.getLogger("edged.outputproc")

#: Seconds the child may take to import its stack and build the plugin.
START_TIMEOUT = 60.0


class OutputProcessDied(RuntimeError):
    """The output's process is gone (killed, crashed): the batch it had is lost."""


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
            self.records.append((record.name, record.levelno, record.getMessage()))
        except Exception:  # a record that cannot be formatted must not stop the output
            self.records.append((record.name, record.levelno, str(record.msg)))

    def take(self) -> list[tuple[str, int, str]]:
        out, self.records = self.records, []
        return out


class _Reporter:
    """What changed in the child's health since the last answer."""

    def __init__(self, health: ComponentHealth, plugin: Any, logs: _Collect) -> None:
        self.health = health
        self.plugin = plugin
        self.logs = logs
        self._sent: dict[str, int] = {}

    def report(self) -> dict[str, Any]:
        h = self.health
        counters = h.counters
        sent = self._sent
        delta = {k: v - sent.get(k, 0) for k, v in counters.items() if v != sent.get(k, 0)}
        if delta:
            self._sent = dict(counters)
        try:
            status = self.plugin.status()
        except Exception as exc:
            status = None
            h.error(f"status: {type(exc).__name__}: {exc}")
        files = getattr(self.plugin, "files", None)
        try:
            ledger = self.plugin.ledger() if hasattr(self.plugin, "ledger") else None
        except Exception as exc:
            ledger = None
            h.error(f"ledger: {type(exc).__name__}: {exc}")
        return {
            "ledger": ledger,
            "counters": delta,
            "state": h.state,
            "last_error": h.last_error,
            "last_error_t": h.last_error_t,
            "info": dict(h.info),
            "status": status,
            "files": None if files is None else [str(f) for f in files],
            "logs": self.logs.take(),
        }


def serve(conn: Connection, plugin_cls: type, config: Any, name: str, vessel_id: str,
          options: dict[str, Any], files: list[str] | None, level: int) -> None:
    """The child's main loop; returns when told to stop or when the parent is gone."""
    ignore_stop_signals()
    from .plugin import PluginContext  # (here: the child imports what it needs only)

    logs = _Collect()
    root = logging.getLogger()
    root.handlers[:] = [logs]
    root.setLevel(level)
    clock = MirroredClock()
    health = ComponentHealth(name, "output", getattr(config, "type", ""), clock)
    ctx = PluginContext(name=name, clock=clock, health=health, publish=lambda rec: None,
                        vessel_id=vessel_id, options=options)
    loop = asyncio.new_event_loop()
    try:
        plugin = plugin_cls(config, ctx)
        if files and isinstance(getattr(plugin, "files", None), list):
            plugin.files.extend(Path(f) for f in files)
    except Exception as exc:
        conn.send(("error", f"{type(exc).__name__}: {exc}", None))
        return
    reporter = _Reporter(health, plugin, logs)
    conn.send(("ok", None, reporter.report()))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):  # the parent died or closed the pipe
            return
        what = msg[0]
        if what == "stop":
            return
        clock.set(msg[1], msg[2])
        value: Any = None
        try:
            if what == "write":
                plugin.write(msg[3])
            elif what == "flush":
                plugin.flush()
            elif what == "rotate":
                plugin.rotate()
            elif what == "open":
                loop.run_until_complete(plugin.open())
            elif what == "ready":
                value = loop.run_until_complete(plugin.ready(msg[3] if len(msg) > 3 else None))
            elif what == "close":
                loop.run_until_complete(plugin.close())
            else:
                raise ValueError(f"unknown call {what!r}")
        except Exception as exc:
            conn.send(("error", f"{type(exc).__name__}: {exc}", reporter.report()))
            continue
        conn.send(("ok", value, reporter.report()))


class ProcessOutput:
    """The parent's side: the output plugin's contract, each call done in the child.

    A call is pickled in the event loop (pickling needs the GIL wherever it is done;
    a helper thread doing it would only contend for it), its bytes go out through a
    writer thread (a pipe the child has not emptied yet must not hold the loop), and
    a receiver thread takes the answers, which come in the order of the calls. The
    host awaits a write's future when it has PROCESS_DEPTH on their way; `flush` and
    `rotate` are not waited for; their answers are applied when they come.
    """

    placement = "process"

    def __init__(self, plugin: Any, name: str, health: ComponentHealth, clock: Clock) -> None:
        self.plugin = plugin
        self.name = name
        self.health = health
        self.clock = clock
        self.config = plugin.config
        self.keys = plugin.keys
        self.exclude_keys = plugin.exclude_keys
        self.files: list[Path] | None = getattr(plugin, "files", None)
        self.process: Any = None
        self._conn: Any = None
        self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"edged-{name}-send")
        self._receiver: threading.Thread | None = None
        self._pending: deque[Future[Any]] = deque()
        self._status: dict[str, Any] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        #: The start under way or done (see `open`).
        self.opening: asyncio.Future[None] | None = None
        #: Records sent to the current process, and its last `ledger` (what counts
        #: exactly what a kill loses: `lost_at_death`); records of writes refused since
        #: it died.
        self._handed = 0
        self._ledger: dict[str, Any] | None = None
        self._refused = 0
        #: The current process's link: marked dead by its receiver at the end of the
        #: pipe, under `_lock`, with which a call is queued (no call waits behind a
        #: process that is gone). One per process: the receiver of a process that
        #: died never marks the next one's.
        self._lock = threading.Lock()
        self._link = _Link(dead=True)

    @property
    def pid(self) -> int | None:
        return None if self.process is None else self.process.pid

    @staticmethod
    def cannot_run(plugin: Any) -> str | None:
        """Why `plugin` cannot be made in a process of its own (its class or its
        configuration cannot be pickled: a class made inside a function), or None."""
        try:
            ForkingPickler.dumps((type(plugin), plugin.config))
        except Exception as exc:
            return f"{type(exc).__name__}: {exc}"
        return None

    # -- start ---------------------------------------------------------------------------
    def _spawn(self) -> dict[str, Any]:
        """(in a thread of the default executor: the child takes a while to start)"""
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe(duplex=True)
        opts = {k: v for k, v in self.plugin.ctx.options.items() if isinstance(v, (str, int, float, bool, type(None)))}
        files = None if self.files is None else [str(f) for f in self.files]
        p = ctx.Process(
            target=serve,
            args=(child, type(self.plugin), self.config, self.name, self.plugin.ctx.vessel_id, opts, files,
                  logging.getLogger().getEffectiveLevel()),
            name=f"edged-{self.name}",
            daemon=True,
        )
        p.start()
        child.close()
        try:
            if not parent.poll(START_TIMEOUT):
                raise OutputProcessDied(f"the output's process did not start within {START_TIMEOUT:g} s")
            msg = parent.recv()
        except (EOFError, OSError):
            msg = ("error", f"the output's process died while starting (exit code {p.exitcode})", None)
        except OutputProcessDied:
            _kill(p, parent)
            raise
        if msg[0] != "ok":
            _kill(p, parent)
            raise RuntimeError(f"the output could not be made in its process: {msg[1]}")
        self.process, self._conn = p, parent
        self._handed = self._refused = 0
        self._ledger = None
        self._link = link = _Link(dead=False)
        self._receiver = threading.Thread(target=self._receive, args=(parent, p, link), name=f"edged-{self.name}-recv",
                                          daemon=True)
        self._receiver.start()
        log.info("output=%s placement=process pid=%s", self.name, p.pid)
        return msg[2]

    # -- the threads ---------------------------------------------------------------------
    def _send(self, conn: Any, data: bytes) -> None:
        try:
            conn.send_bytes(data)
        except (OSError, ValueError):
            pass  # the child is gone: the receiver sees the end of the pipe and says so

    def _receive(self, conn: Any, p: Any, link: "_Link") -> None:
        """Answers, in the order of the calls, onto their futures; at the end of the
        pipe (the child died or was stopped) every call still waiting fails."""
        pending = self._pending
        while True:
            try:
                answer = conn.recv()
            except (EOFError, OSError):
                break
            fut = pending.popleft()
            if answer[0] == "ok":
                fut.set_result((answer[1], answer[2]))
            else:
                fut.set_exception(_Failed(answer[1], answer[2]))
        p.join(1.0)
        why = OutputProcessDied(f"the output's process ended (exit code {p.exitcode})")
        with self._lock:  # no call is queued behind this: it would wait for ever
            link.dead = True
            left = list(pending)
            pending.clear()
        for fut in left:
            fut.set_exception(why)

    # -- the event loop's side -------------------------------------------------------------
    def _submit(self, what: str, arg: Any = None, now: float | None = None, mono: float | None = None) -> "Future[Any]":
        fut: Future[Any] = Future()
        conn = self._conn
        link = self._link
        if conn is None or link.dead:
            return self._gone(fut, what, arg)
        if now is None or mono is None:
            now, mono = self.clock.now(), self.clock.monotonic()
        msg = (what, now, mono) if arg is None else (what, now, mono, arg)
        data = ForkingPickler.dumps(msg, pickle.HIGHEST_PROTOCOL)
        loop = self._loop
        if loop is not None:
            fut.add_done_callback(lambda f: loop.call_soon_threadsafe(self._answered, f))
        with self._lock:
            if link.dead:  # the receiver saw the end of the pipe meanwhile
                return self._gone(fut, what, arg)
            self._pending.append(fut)
            if what == "write":
                self._handed += len(arg)
        self._writer.submit(self._send, conn, data)
        return fut

    def _gone(self, fut: "Future[Any]", what: str, arg: Any) -> "Future[Any]":
        """A call made when the process is gone: a write fails (its records are lost and
        counted), anything else has nothing to do it to."""
        if what == "write":
            self._refused += len(arg)
            fut.set_exception(OutputProcessDied("the output's process is gone"))
        else:
            fut.set_result((None, None))
        return fut

    def _answered(self, fut: "Future[Any]") -> None:
        """Apply an answer's report (in the loop's thread, in the order of the calls)."""
        exc = fut.exception()
        if isinstance(exc, _Failed):
            self._apply(exc.report)
        elif exc is None:
            self._apply(fut.result()[1])

    async def _call(self, what: str, arg: Any = None) -> Any:
        self._loop = asyncio.get_running_loop()
        try:
            # shielded: a cancelled wait (shutdown) must not cancel a call on its way
            value, _ = await asyncio.shield(asyncio.wrap_future(self._submit(what, arg)))
        except _Failed as exc:
            raise RuntimeError(exc.message) from None
        return value

    def _apply(self, report: dict[str, Any] | None) -> None:
        if not report:
            return
        h = self.health
        for name, level, text in report["logs"]:
            logging.getLogger(name).log(level, "%s", text)
        for k, n in report["counters"].items():
            h.count(k, n)
        # (the child logged its state changes and errors: they are not logged again)
        if report["state"] != "created" and report["state"] != h.state:
            h.state = report["state"]
        if report["last_error"] is not None and report["last_error_t"] != h.last_error_t:
            h.last_error = report["last_error"]
            h.last_error_t = report["last_error_t"]
        h.info.update(report["info"])
        self._status = report["status"]
        self._ledger = report.get("ledger")
        if report["files"] is not None and self.files is not None:
            self.files[:] = [Path(f) for f in report["files"]]

    async def open(self) -> None:
        """Start the process (the first time, or again after a failure) and open the
        plugin there. Shielded: a shutdown while the child starts waits for it
        (`opening`) and then gives it what was queued, instead of leaving it behind."""
        self._loop = asyncio.get_running_loop()
        self.opening = asyncio.ensure_future(self._open())
        await asyncio.shield(self.opening)

    async def _open(self) -> None:
        if self._conn is None:
            self._apply(await asyncio.get_running_loop().run_in_executor(None, self._spawn))
        await self._call("open")

    def write_future(self, batch: list[Any], now: float, mono: float) -> "asyncio.Future[Any]":
        """The batch on its way (behind what was asked before), to be written with the
        clock reading `now`, `mono` (as it read when the batch was taken); the future
        is done when the child has written it, and raises `OutputProcessDied` or
        `_Failed` (see `failure`) when it was not."""
        self._loop = loop = asyncio.get_running_loop()
        return asyncio.wrap_future(self._submit("write", batch, now, mono), loop=loop)

    @staticmethod
    def failure(exc: BaseException) -> BaseException:
        """What a failed write's future raised, as the host should see it."""
        return RuntimeError(exc.message) if isinstance(exc, _Failed) else exc

    def write(self, batch: list[Any]) -> None:
        """(the final drain at shutdown: queued behind what is on its way)"""
        self._submit("write", batch)

    async def ready(self, timeout: float | None = None) -> bool:
        """Once the process has started and opened the plugin (a replay must not
        begin while it starts: its first batch would hold seconds of data), the
        plugin's own answer."""
        if self.opening is not None:
            try:
                await asyncio.shield(self.opening)
            except Exception:
                return False
        return bool(await self._call("ready", timeout))

    def flush(self) -> None:
        self._submit("flush")

    def rotate(self) -> None:
        self._submit("rotate")

    def status(self) -> dict[str, Any] | None:
        return self._status

    async def close(self) -> None:
        """Close the plugin in its process (after what is on its way), then let the
        process go."""
        try:
            await self._call("close")
        finally:
            p, conn, rx = self.process, self._conn, self._receiver
            self.process = self._conn = self._receiver = None
            if p is not None:
                await asyncio.get_running_loop().run_in_executor(None, _stop, p, conn, rx, self._writer)

    def lost_at_death(self, unanswered: int) -> int:
        """The records a dead process took with it. The plugin counts them from its
        last ledger and what it left (a recorder reads its file past its last flush):
        exact, where the writes that got no answer (`unanswered` records, the count
        when the plugin cannot tell) miss a recorder's chunk that was still open. The
        writes refused since the death are lost as well."""
        try:
            lost = self.plugin.lost_at_death(self._handed, self._ledger)
        except Exception as exc:  # a plugin's count must not stop the restart
            self.health.error(f"lost_at_death: {type(exc).__name__}: {exc}")
            lost = None
        return (unanswered - self._refused if lost is None else int(lost)) + self._refused

    def kill_now(self) -> None:
        """From the event loop, when closing did not end in time: the child goes at once."""
        sigkill(self.process)


def sigkill(p: Any) -> None:
    """SIGKILL a child process at once, if it is there (without waiting for it)."""
    if p is not None and p.pid is not None:
        try:
            os.kill(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def _stop(p: Any, conn: Any, rx: threading.Thread | None, writer: ThreadPoolExecutor) -> None:
    """Tell the child to stop (behind everything sent before) and wait for it."""
    writer.submit(_send_stop, conn).result()
    p.join(5.0)
    _kill(p, conn)
    if rx is not None:
        rx.join(5.0)


def _send_stop(conn: Any) -> None:
    try:
        conn.send(("stop",))
    except (OSError, ValueError):
        pass


def _kill(p: Any, conn: Any) -> None:
    if p.is_alive():
        try:
            os.kill(p.pid, signal.SIGKILL)
        except (ProcessLookupError, TypeError):
            pass
    p.join(5.0)
    try:
        conn.close()
    except OSError:
        pass


class _Link:
    """One process's pipe, as its receiver last saw it."""

    __slots__ = ("dead",)

    def __init__(self, dead: bool) -> None:
        self.dead = dead


class _Failed(Exception):
    """A call the plugin raised on in its process (the process itself goes on)."""

    def __init__(self, message: str, report: dict[str, Any] | None) -> None:
        super().__init__(message)
        self.message = message
        self.report = report
