"""Where an output runs (its *placement*): in the event loop (`LoopOutput`) or in a
process of its own (`ProcessOutput`, `worker = "process"` in its table), behind one
interface, so that the `OutputHost` never asks which it has.

Why a process: a recorder's work (JSON, MCAP chunks, compression, fsync) is as large
as the decoding itself in a fast replay, and a slow disk must never hold the event
loop. In a process of its own it uses the machine's second core and stalls only
itself.

The process host (`edged.childproc`) carries the plugin contract's calls, in order:
`open`, `write` (a batch), `flush`, `rotate`, `ready` (a timeout), `close`, each with
the parent's clock as the host read it (for a write: when it took the batch), so that
the plugin writes what it would have written in the loop. Each answer's report
mirrors the child's health into the parent's component: counters (as increments),
state, last error, info; `status()`; the plugin's `ledger()` (what counts exactly what
a kill loses: `lost_at_death`); and the plugin's `files` (what a recorder has
written), which the parent keeps and gives back to the next process after a restart,
so that a restarted recorder numbers its next file on instead of overwriting the last.
The child's log comes back with each answer too (the process host's job).
"""

from __future__ import annotations

import asyncio
import logging
from multiprocessing.reduction import ForkingPickler
from pathlib import Path
from typing import Any

from .childmain import CallFailed
from .childproc import WATCHED, ChildDied, ChildGone, ChildProcess, forget
from .clock import Clock
from .health import ComponentHealth
from .plugin import OutputPlugin

__all__ = ["LoopOutput", "ProcessOutput", "place_output", "PROCESS_BATCH", "PROCESS_DEPTH"]

log = logging.getLogger("edged.outputproc")

#: Records per message to an output's process: large enough that the exchange's own
#: cost is small beside the records', small beside a pipe's buffer many times over.
PROCESS_BATCH = 4096
#: Batches on their way to an output's process at once.
PROCESS_DEPTH = 4
#: Records the loop placement takes from its queue at once (the queue's own default).
LOOP_BATCH = 1024


def place_output(plugin: Any, name: str, health: ComponentHealth, clock: Clock) -> "LoopOutput | ProcessOutput":
    """The placement its configuration asks for; in the loop, with a warning, when the
    plugin cannot be made in a process (its class or configuration cannot be pickled:
    a class made inside a function)."""
    if plugin.config.worker == "process":
        try:
            ForkingPickler.dumps((type(plugin), plugin.config))
        except Exception as exc:
            why = f"cannot run in a process: {type(exc).__name__}: {exc}"
            log.warning("event=output-in-loop output=%s reason=%r", name, why)
            health.info["worker"] = "loop"
        else:
            return ProcessOutput(plugin, name, health, clock)
    return LoopOutput(plugin)


class LoopOutput:
    """The plugin in the event loop: every call made here and now. A write is done
    when `send` returns (it raises what the plugin raised): nothing is on its way."""

    placement = "loop"
    batch = LOOP_BATCH
    depth = 1
    pid = None

    def __init__(self, plugin: Any) -> None:
        self.plugin = plugin
        self._open = False

    @property
    def files(self) -> list[Path] | None:
        return getattr(self.plugin, "files", None)

    async def open(self) -> None:
        await self.plugin.open()
        self._open = True

    @property
    def up(self) -> bool:
        """Open."""
        return self._open

    async def started(self) -> bool:
        """(nothing starts in the background here)"""
        return False

    def send(self, batch: list[Any], now: float, mono: float) -> None:
        self.plugin.write(batch)

    def write(self, batch: list[Any]) -> None:
        self.plugin.write(batch)

    async def ready(self, timeout: float | None = None) -> bool:
        return await self.plugin.ready(timeout)

    def flush(self) -> None:
        self.plugin.flush()

    def rotate(self) -> None:
        self.plugin.rotate()

    def status(self) -> dict[str, Any] | None:
        return self.plugin.status()

    async def close(self) -> None:
        """Close the plugin, once, if it was opened."""
        if self._open:
            self._open = False
            await self.plugin.close()

    def kill_now(self) -> None:
        """(nothing runs elsewhere)"""


class _OutputServant:
    """(in the child) The plugin, made there; each call of its contract, and what
    changed in its health since the last answer."""

    def __init__(self, plugin: Any, health: ComponentHealth) -> None:
        self.plugin = plugin
        self.health = health
        self.loop = asyncio.new_event_loop()
        self._sent: dict[str, int] = {}
        #: Why the last open failed (None: it did not): the calls sent behind it say so.
        self.open_failed: str | None = None

    def call(self, what: str, arg: Any) -> Any:
        plugin = self.plugin
        if what == "open":
            self.open_failed = None
            try:
                return self.loop.run_until_complete(plugin.open())
            except Exception as exc:
                self.open_failed = f"{type(exc).__name__}: {exc}"
                raise
        if self.open_failed is not None and what in ("write", "flush", "rotate"):
            raise RuntimeError(f"not open (open: {self.open_failed})")
        if what == "write":
            return plugin.write(arg)
        if what == "flush":
            return plugin.flush()
        if what == "rotate":
            return plugin.rotate()
        if what == "ready":
            return self.loop.run_until_complete(plugin.ready(arg))
        if what == "close":
            return self.loop.run_until_complete(plugin.close())
        raise ValueError(f"unknown call {what!r}")

    def _guarded(self, what: str) -> Any:
        try:
            return getattr(self.plugin, what)()
        except Exception as exc:  # a plugin's report must not stop the output
            self.health.error(f"{what}: {type(exc).__name__}: {exc}")
            return None

    def report(self) -> dict[str, Any]:
        h = self.health
        counters = h.counters
        sent = self._sent
        delta = {k: v - sent.get(k, 0) for k, v in counters.items() if v != sent.get(k, 0)}
        if delta:
            self._sent = dict(counters)
        status = self._guarded("status")
        ledger = self._guarded("ledger") if hasattr(self.plugin, "ledger") else None
        files = getattr(self.plugin, "files", None)
        return {"ledger": ledger, "counters": delta, "state": h.state, "last_error": h.last_error,
                "last_error_t": h.last_error_t, "info": dict(h.info), "status": status,
                "files": None if files is None else [str(f) for f in files]}


def make_output_servant(clock: Any, plugin_cls: type, config: Any, name: str, vessel_id: str,
                        options: dict[str, Any], files: list[str] | None, config_dir: str) -> _OutputServant:
    """(in the child) The plugin made again there, given the files its predecessor
    wrote; paths in its configuration (a zenoh output's TLS files) are relative to the
    configuration file's folder, as in the parent."""
    from .plugin import PluginContext  # (here: the child imports what it needs only)

    health = ComponentHealth(name, "output", config.type, clock)
    ctx = PluginContext(name=name, clock=clock, health=health, publish=lambda rec: None,
                        vessel_id=vessel_id, options=options, config_dir=Path(config_dir))
    plugin = plugin_cls(config, ctx)
    if files and isinstance(getattr(plugin, "files", None), list):
        plugin.files.extend(Path(f) for f in files)
    return _OutputServant(plugin, health)


class ProcessOutput:
    """The plugin in a process of its own. The host has up to PROCESS_DEPTH writes on
    their way (`send` returns each one's future); `flush` and `rotate` are not waited
    for, their answers are applied when they come."""

    placement = "process"
    batch = PROCESS_BATCH
    depth = PROCESS_DEPTH

    def __init__(self, plugin: Any, name: str, health: ComponentHealth, clock: Clock) -> None:
        self.plugin = plugin
        self.name = name
        self.health = health
        self.files: list[Path] | None = getattr(plugin, "files", None)
        self.child = ChildProcess(name, make_output_servant, clock, plugin.config.watchdog, self._apply)
        self._status: dict[str, Any] | None = None
        #: The start under way or done (see `open`).
        self.opening: asyncio.Future[None] | None = None
        #: Records sent to the current process, and its last `ledger` (what counts
        #: exactly what a kill loses: `lost_at_death`); records of writes refused since
        #: it died.
        self._handed = 0
        self._ledger: dict[str, Any] | None = None
        self._refused = 0

    @property
    def pid(self) -> int | None:
        return self.child.pid

    @property
    def _pending(self) -> Any:
        """The calls on their way to the process (none: every write answered)."""
        return self.child.pending

    def _apply(self, report: dict[str, Any] | None) -> None:
        """An answer's report, in the loop's thread, in the order of the calls."""
        if not report:
            return
        h = self.health
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
        self._ledger = report["ledger"]
        if report["files"] is not None and self.files is not None:
            self.files[:] = [Path(f) for f in report["files"]]

    async def _call(self, what: str, arg: Any = None, limit: float | None = WATCHED) -> Any:
        """A call waited for (shielded: a cancelled wait, at shutdown, must not cancel
        a call on its way). One made when the process is gone has nothing to do it to."""
        fut = self.child.submit(what, arg, limit=limit)
        forget(fut)
        try:
            return await asyncio.shield(fut)
        except ChildGone:
            return None
        except CallFailed as exc:
            raise RuntimeError(exc.message) from None

    async def open(self) -> None:
        """Start the process (the first time, or again after a failure) and ask it to
        open the plugin, without waiting for either: the host takes and sends its
        batches at once, behind the open, with the clock as it then reads, so that the
        process is given the very calls the loop placement makes (a replay reads on
        while the child imports its stack). `opening` is the open's answer; a start or
        an open that failed fails the writes behind it, and so the host's run."""
        if not self.child.alive:
            self._handed = self._refused = 0
            self._ledger = None
            opts = {k: v for k, v in self.plugin.ctx.options.items()
                    if isinstance(v, (str, int, float, bool, type(None)))}
            files = None if self.files is None else [str(f) for f in self.files]
            forget(self.child.launch((type(self.plugin), self.plugin.config, self.name, self.plugin.ctx.vessel_id,
                                      opts, files, str(self.plugin.ctx.config_dir)), "output"))
        self.opening = asyncio.ensure_future(self._call("open"))
        forget(self.opening)

    @property
    def up(self) -> bool:
        """Its process started and its open answered (what `open` does not wait for)."""
        f = self.opening
        return f is not None and f.done() and not f.cancelled() and f.exception() is None and self.child.alive

    async def started(self) -> bool:
        """Stopped while its process was starting: True once it is up and open (it
        then takes what was queued). False for a process that died since it opened
        (waiting for its restart): nothing there takes the queue."""
        if self.opening is None:
            return False
        try:
            await self.opening
        except Exception as exc:
            self.health.error(f"open: {type(exc).__name__}: {exc}")
            return False
        return self.child.alive

    def send(self, batch: list[Any], now: float, mono: float) -> "asyncio.Future[Any]":
        """The batch on its way (behind what was asked before), to be written with the
        clock reading `now`, `mono` (as it read when the batch was taken); the future
        is done when the child has written it (see `failed` for when it was not)."""
        fut = self.child.submit("write", batch, now=now, mono=mono)
        if fut.done():  # refused: the process is gone
            self._refused += len(batch)
        else:
            self._handed += len(batch)
        return fut

    def failed(self, exc: BaseException, unanswered: int) -> BaseException:
        """A write failed, with `unanswered` records on their way: what the host then
        raises. A process that died took those records with it, counted here."""
        if isinstance(exc, ChildDied):
            self.health.count("dropped.process_died", self.lost_at_death(unanswered))
            return exc
        return RuntimeError(exc.message) if isinstance(exc, CallFailed) else exc

    def write(self, batch: list[Any]) -> None:
        """(the final drain at shutdown: queued behind what is on its way) A batch the
        process can no longer take raises, so that the host counts it lost."""
        fut = self.send(batch, self.child.clock.now(), self.child.clock.monotonic())
        forget(fut)
        if fut.done():  # refused: the process is gone
            raise ChildGone(f"{self.name}'s process is gone: {len(batch)} records not written")

    async def ready(self, timeout: float | None = None) -> bool:
        """A plugin that links to nothing (the base `ready`, such as the recorder) is
        ready at once: the replay reads its first records while the process starts
        (issue 34's start-up); they go behind the start, at most `depth` batches, and
        the replay waits while the host has no room. Any other, once the process has
        started and opened the plugin, answers itself (not watched: its own bound)."""
        if type(self.plugin).ready is OutputPlugin.ready:
            return True
        if self.opening is not None:
            try:
                await asyncio.shield(self.opening)
            except Exception:
                return False
        return bool(await self._call("ready", timeout, limit=None))

    def flush(self) -> None:
        forget(self.child.submit("flush"))

    def rotate(self) -> None:
        forget(self.child.submit("rotate"))

    def status(self) -> dict[str, Any] | None:
        return self._status

    async def close(self) -> None:
        """Close the plugin in its process (after what is on its way), then let the
        process go."""
        try:
            await self._call("close")
        finally:
            self.opening = None
            await self.child.stop()

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
        self.child.kill_now()
