"""Estimator workers: one core each, fed in a deterministic order, live and in replay.

Replay equals live, chained estimators included (DESIGN §2). A worker's inputs are
measurements from the router and estimates of the workers it consumes (the draft
worker takes `est/stw`). Live, those arrive in an order that depends on scheduling;
the host puts them back into one order that depends only on the data:

- the router numbers every record it publishes (`Router.seq`); an estimate carries
  the number of the record it was made from (its *cause*);
- a worker orders its inputs by (number, producer, production order): a measurement
  first, then what its upstream workers made from it, in the configuration's
  topological order of those workers;
- it steps its core only up to its *bound*: the highest number below which nothing
  can still arrive, i.e. everything the router has published and everything its
  upstream workers have finished (their *watermark*). A worker with nothing to do is
  finished up to its own bound, so an idle upstream never holds a downstream back.

Time for cores is data time. Records carry it; health snapshots (1 Hz, published
through the router like any record) are the beacons that move it on when no input
arrives. Before a record of time t is stepped, every tick k/rate <= t of the worker's
grid is fired: publication at `publish_rate` and `stale` marking come from those
ticks, so the same log gives the same ticks at any replay speed.

Placement: a `LoopRunner` calls the core in the event loop; a `ProcessRunner` sends
batches of calls to a process of its own (`edged.workerproc`) from a helper thread, so
the loop never waits on it. A core that raises, dies or hangs past the watchdog makes
`run()` raise: the runtime's supervisor restarts it with backoff and reports it.
"""

from __future__ import annotations

import asyncio
import collections
import heapq
import itertools
import logging
import math
import multiprocessing
import os
import signal
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Iterable

from .health import ComponentHealth
from .plugin import EstimatorPlugin
from .records import Estimate, HealthRecord
from .router import Router
from .signals import StopRequested, step as core_step
from .outputproc import sigkill
from .workerproc import core_health, run_calls, serve

__all__ = ["WorkerHost", "LoopRunner", "ProcessRunner", "CoreFailed", "MAX_CALLS", "MAX_CATCHUP_TICKS"]

log = logging.getLogger("edged.workers")

#: Calls made in one batch: in the loop, between two chances for the inputs to run; to
#: a process, per batch (preparing one and applying the last one's answers, back to
#: back when the worker is saturated, hold the loop for about 1.2 ms per 512 calls
#: each: 1024 made a 5-ms stall), sent as messages of CHUNK_PROCESS calls (pickling
#: one holds the interpreter: 256 calls cost about 0.3 ms each way).
MAX_CALLS = 1024
MAX_CALLS_PROCESS = 512
#: Calls per message to a process. The next message goes before the answer to the
#: last is read, so that the child always has work: one message at a time, it sat idle
#: while its answer travelled back and the loop got round to it (half the time, with
#: the draft estimator's 600 readings a second).
CHUNK_PROCESS = 256
#: Ticks fired at once when data time jumps (a gap in a log): beyond, the grid skips
#: to the latest tick (counted `ticks_skipped`) instead of firing hours of them.
MAX_CATCHUP_TICKS = 1000
#: Producer rank of router records (measurements, health): before every estimate.
_MEASUREMENT_RANK = -1
#: The queue item that only wakes a worker (an upstream worker finished a batch).
_WAKE = (0, None)

Call = tuple[str, Any]


class CoreFailed(RuntimeError):
    """A core raised, died or hung; `results` are those of the calls before it."""

    def __init__(self, message: str, results: list[list[Any]]) -> None:
        super().__init__(message)
        self.results = results


def _is_input(rec: Any) -> bool:
    """A record for the core (not a wake-up, not a health beacon): what a drop loses."""
    return rec is not None and rec.__class__ is not HealthRecord


# -- runners: where the core runs ---------------------------------------------------
class LoopRunner:
    """Calls the core in the event loop."""

    placement = "loop"
    max_calls = MAX_CALLS

    def __init__(self, plugin: EstimatorPlugin) -> None:
        self.plugin = plugin
        self.core: Any = plugin.make_core()
        self.health_report: dict[str, Any] | None = None

    async def start(self) -> None:
        if self.core is None:
            self.core = self.plugin.make_core()

    async def call(self, calls: list[Call]) -> list[list[Any]]:
        results: list[list[Any]] = []
        try:
            with core_step():
                run_calls(self.core, calls, results)
        except Exception as exc:
            raise CoreFailed(f"{type(exc).__name__}: {exc}", results) from exc
        except StopRequested as exc:  # a stop signal, and the step would not end
            raise CoreFailed(f"stopped: {exc}", results) from None
        return results

    def report(self) -> dict[str, Any] | None:
        return core_health(self.core) if self.core is not None else self.health_report

    async def stop(self) -> None:
        """Forget the core: the next start() makes a fresh one. Its last health is kept,
        so the final snapshot (after a replay) describes the whole run."""
        if self.core is not None:
            self.health_report = core_health(self.core)
        self.core = None


class ProcessRunner:
    """Runs the core in a process of its own; every exchange goes through one helper
    thread, so the event loop only awaits a future."""

    placement = "process"
    max_calls = MAX_CALLS_PROCESS

    def __init__(self, plugin: EstimatorPlugin, name: str, watchdog: float) -> None:
        self.plugin = plugin
        self.name = name
        self.watchdog = watchdog
        self.process: Any = None
        self._conn: Any = None
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"edged-{name}")
        self.health_report: dict[str, Any] | None = None
        self.starts = 0

    @property
    def pid(self) -> int | None:
        return None if self.process is None else self.process.pid

    async def start(self) -> None:
        if self.process is not None and self.process.is_alive():
            return
        await asyncio.get_running_loop().run_in_executor(self._pool, self._spawn)

    def _spawn(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe(duplex=True)
        p = ctx.Process(
            target=serve,
            args=(child, type(self.plugin), self.plugin.config, self.name, self.plugin.ctx.vessel_id),
            name=f"edged-{self.name}",
            daemon=True,
        )
        p.start()
        child.close()
        self.process, self._conn = p, parent
        self.starts += 1
        # Importing numpy and a filter stack may take a while on a small gateway.
        msg = self._recv(max(self.watchdog, 60.0), "start")
        if msg[0] != "ready":
            self._kill()
            raise CoreFailed(f"core did not start: {msg[2] if len(msg) > 2 else msg}", [])
        log.info("worker=%s placement=process pid=%s", self.name, p.pid)

    def _recv(self, timeout: float, what: str) -> Any:
        conn = self._conn
        try:
            ready = conn.poll(timeout)
        except (EOFError, OSError):
            ready = True  # recv() below reports how it ended
        if not ready:
            self._kill()
            raise CoreFailed(f"watchdog: no answer from the core's process within {timeout:g} s ({what}); killed", [])
        try:
            return conn.recv()
        except (EOFError, OSError):
            raise self._died() from None

    def _died(self) -> CoreFailed:
        """The pipe broke, on a send or a receive (which one first is a race): one
        report either way, with the exit code the operator needs (-9: killed)."""
        code = None
        if self.process is not None:
            self.process.join(1.0)
            code = self.process.exitcode
        self._kill()
        return CoreFailed(f"the core's process died (exit code {code})", [])

    def _send(self, calls: list[Call]) -> None:
        if self._conn is None:  # killed after a failure while this batch waited its turn
            raise CoreFailed("the core's process is gone", [])
        try:
            self._conn.send(("calls", calls))
        except (OSError, ValueError):  # BrokenPipe: the child is gone
            raise self._died() from None

    def _exchange(self, calls: list[Call]) -> list[list[Any]]:
        """The calls in messages of CHUNK_PROCESS, at most two on their way at once
        (each small beside a pipe's buffer, so that neither side blocks the other)."""
        chunks = [calls[i : i + CHUNK_PROCESS] for i in range(0, len(calls), CHUNK_PROCESS)]
        results: list[list[Any]] = []
        self._send(chunks[0])
        for i in range(len(chunks)):
            if i + 1 < len(chunks):
                self._send(chunks[i + 1])
            msg = self._recv(self.watchdog, "batch")
            if msg[0] == "ok":
                self.health_report = msg[2]
                results.extend(msg[1])
                continue
            # (a message sent after the failing one is answered too; the supervisor
            # stops this child before it starts the core again, and that answer goes)
            self.health_report = msg[3] if len(msg) > 3 else None
            raise CoreFailed(msg[2], results + msg[1])
        return results

    async def call(self, calls: list[Call]) -> list[list[Any]]:
        return await asyncio.get_running_loop().run_in_executor(self._pool, self._exchange, calls)

    def report(self) -> dict[str, Any] | None:
        return self.health_report

    def _kill(self) -> None:
        p, self.process = self.process, None
        conn, self._conn = self._conn, None
        if conn is not None:
            try:
                conn.close()
            except OSError:
                pass
        if p is not None:
            if p.is_alive():
                try:
                    os.kill(p.pid, signal.SIGKILL)
                except (ProcessLookupError, TypeError):
                    pass
            p.join(5.0)

    def _stop_child(self) -> None:
        p, conn = self.process, self._conn
        if p is None:
            return
        try:
            conn.send(("stop",))
            p.join(2.0)
        except (OSError, ValueError):
            pass
        self._kill()

    async def stop(self) -> None:
        await asyncio.get_running_loop().run_in_executor(self._pool, self._stop_child)

    def kill_now(self) -> None:
        """From the event loop, when a batch did not come back in time at shutdown:
        the child goes at once (the helper thread's wait then ends)."""
        sigkill(self.process)

    def close(self) -> None:
        """Last words at shutdown: the child and the helper thread go."""
        self._stop_child()
        self._pool.shutdown(wait=False)


# -- the host -----------------------------------------------------------------------
class WorkerHost:
    """Hosts one estimator core: orders its inputs, fires its ticks, publishes its
    estimates under the instance's name, marks them stale, reports its health."""

    def __init__(
        self,
        name: str,
        plugin: EstimatorPlugin,
        router: Router,
        health: ComponentHealth,
    ) -> None:
        self.name = name
        self.plugin = plugin
        self.router = router
        self.health = health
        cfg = plugin.config
        self.kind: str | None = getattr(plugin, "kind", None)
        self.window: float = float(getattr(cfg, "reorder_window", 0.0))
        self.publish_rate: float = float(getattr(cfg, "publish_rate", 0.0))
        self.stale_after: float = float(getattr(cfg, "stale_after", 0.0))
        placement = getattr(cfg, "worker", "loop")
        self.runner: LoopRunner | ProcessRunner
        if placement == "process":
            self.runner = ProcessRunner(plugin, name, float(getattr(cfg, "watchdog", 10.0)))
            probe = plugin.make_core()  # what it consumes and whether it ticks
        else:
            self.runner = LoopRunner(plugin)
            probe = self.runner.core
        self.inputs: frozenset[str] = frozenset(probe.inputs)
        self.ticks_core = callable(getattr(probe, "tick", None))
        #: Other workers whose estimates this one consumes (set by the runtime).
        self.upstream: list[WorkerHost] = []
        self.downstream: list[WorkerHost] = []
        #: Topological position: orders the estimates of several upstream workers.
        self.rank = 0
        self._ranks: dict[str, int] = {}
        sources = getattr(cfg, "sources", None)
        if sources is not None:  # upstream estimates and health beacons pass the filter
            sources = set(sources) | {k[4:] for k in self.inputs if k.startswith("est/")} | {HealthRecord.source}
        self.sub = router.subscribe(
            f"estimator:{name}",
            self.inputs | {HealthRecord.route_key},
            maxsize=int(getattr(cfg, "queue_size", 10_000)),
            health=health,
            sources=sources,
            preferred_only=bool(getattr(cfg, "preferred_only", True)),
            reorder_window=None,
            sequenced=True,
        )
        self.task: asyncio.Task[None] | None = None
        # Ordering state.
        #: (seq, producer rank, n, record), kept sorted: the inputs in the order they
        #: are stepped
        self._pending: collections.deque[tuple[int, int, int, Any]] = collections.deque()
        self._n = itertools.count()
        self._done = 0  # watermark: everything caused by numbers <= this is published
        self._busy = False
        #: Batches on their way to the core, oldest first: (answer, calls, causes,
        #: watermark once applied). A process takes the next before the last is
        #: applied; the loop, one at a time.
        self._progress: asyncio.Future[None] | None = None  # see progress()
        self._inflight: collections.deque[tuple[asyncio.Future[list[list[Any]]], list[Call], list[int], int]] = \
            collections.deque()
        self.depth = 2 if placement == "process" else 1
        self._closing = False
        self._finished = False  # nothing more will be published (finished or gave up)
        self._finish_ran = False
        #: Failures in a row after which the worker gives up (replay: a core that fails
        #: on every attempt would otherwise be restarted for ever and hold the replay);
        #: None: never (live, the supervisor's backoff spaces the attempts).
        self.give_up_after: int | None = None
        self._failures = 0
        self.gave_up = False
        # Data time, reorder window, ticks.
        self._reorder: list[tuple[float, int, Any]] = []
        self._newest = -math.inf  # newest input time admitted
        self._stepped = -math.inf  # newest input time stepped (older inputs are late)
        self._ticking = self.publish_rate > 0 or self.stale_after > 0 or self.ticks_core
        #: The next tick is k / rate: an integer, so that the grid never drifts and
        #: every run (live, a replay from any file) fires the very same tick times.
        self._rate = self.publish_rate if self.publish_rate > 0 else 1.0
        self._next_k: int | None = None
        # Publication state (results are applied in order, after the calls).
        self._last_input_t: float | None = None
        self._held: Estimate | None = None
        self._last: Estimate | None = None
        self._stale = False
        self.health.info["placement"] = self.runner.placement
        self.health.info["inputs"] = sorted(self.inputs)

    # -- ordering -------------------------------------------------------------------
    def watermark(self) -> int:
        """Every estimate this worker will make from records numbered <= this is
        already published."""
        if self._finished:
            return self.router.seq
        if self._busy or self._pending or len(self.sub.queue):
            return self._done
        return self.bound()

    def bound(self) -> int:
        """Numbers up to which this worker has all its inputs."""
        b = self.router.seq
        for up in self.upstream:
            w = up.watermark()
            if w < b:
                b = w
        return b

    def wake(self) -> None:
        self.sub.queue.put(_WAKE)

    def link(self, upstream: list["WorkerHost"], rank: int) -> None:
        """Set by the runtime once every worker exists: whose estimates this one
        consumes, and its place in the topological order."""
        self.upstream = upstream
        self.rank = rank
        for u in upstream:
            u.downstream.append(self)
        self._ranks = {f"est/{u.name}": u.rank for u in upstream}

    def _take(self, items: Iterable[tuple[int, Any]]) -> None:
        """Queue the inputs in (number, producer rank) order. They nearly always come
        in that order already (measurements straight from the router): appended, with
        no heap of the whole backlog (at a replay's rate the backlog is tens of
        thousands, and a heap's pop cost a few µs each). An upstream estimate
        carries the number of the record it was made from, so it arrives after
        records numbered later: then one merge of the two sorted runs (Python's sort
        is linear on runs)."""
        ranks = self._ranks
        n = self._n
        new = [(seq, ranks.get(rec.route_key, _MEASUREMENT_RANK) if ranks else _MEASUREMENT_RANK, next(n), rec)
               for seq, rec in items if rec is not None]
        if not new:
            return
        pending = self._pending
        if (not pending or pending[-1] < new[0]) and all(a < b for a, b in zip(new, itertools.islice(new, 1, None))):
            pending.extend(new)
        else:
            pending.extend(new)
            self._pending = collections.deque(sorted(pending))

    def _admit(self, seq: int, rec: Any, calls: list[Call], causes: list[int]) -> None:
        """One input in sequence order: ticks up to its time, then its step(s)."""
        t = rec.t
        if rec.__class__ is HealthRecord:
            # A beacon: data time moves on. With a reorder window, only to its horizon:
            # what is still held there is stepped first, in time order, as a later
            # input would have released it.
            if self.window > 0.0:
                t -= self.window
                while self._reorder and self._reorder[0][0] <= t:
                    self._step_call(heapq.heappop(self._reorder)[2], seq, calls, causes)
            self._tick_to(t, seq, calls, causes)
            return
        if self.window > 0.0:
            if t < self._newest - self.window or t < self._stepped:
                self._late()
                return
            heapq.heappush(self._reorder, (t, next(self._n), rec))
            if t > self._newest:
                self._newest = t
            horizon = self._newest - self.window
            while self._reorder and self._reorder[0][0] <= horizon:
                self._step_call(heapq.heappop(self._reorder)[2], seq, calls, causes)
            return
        if t < self._stepped:
            self._late()
            return
        self._step_call(rec, seq, calls, causes)

    def _late(self) -> None:
        self.health.count("late")

    def _step_call(self, rec: Any, seq: int, calls: list[Call], causes: list[int]) -> None:
        self._tick_to(rec.t, seq, calls, causes)
        if rec.t > self._stepped:
            self._stepped = rec.t
        calls.append(("step", rec))
        causes.append(seq)

    def _tick_at(self) -> float:
        """The data time from which `_tick_to` has a tick to make (−inf: it has not
        seen a time yet; inf: no ticks)."""
        if not self._ticking:
            return math.inf
        k = self._next_k
        return -math.inf if k is None else k / self._rate

    def _tick_to(self, t: float, seq: int, calls: list[Call], causes: list[int]) -> None:
        if not self._ticking or not math.isfinite(t):
            return
        rate = self._rate
        k = self._next_k
        if k is None:  # the grid is absolute: k / rate in data time
            self._next_k = math.floor(t * rate) + 1
            return
        if k / rate > t:
            return
        last = math.floor(t * rate)  # the latest tick at or before t
        if last / rate > t:  # floor of a product that rounded up
            last -= 1
        n = last - k + 1
        if n > MAX_CATCHUP_TICKS:
            self.health.count("ticks_skipped", n - 1)
            k = last
            n = 1
        for i in range(k, k + n):
            calls.append(("tick", i / rate))
            causes.append(seq)
        self._next_k = k + n

    def _flush_reorder(self, seq: int, calls: list[Call], causes: list[int]) -> None:
        while self._reorder:
            self._step_call(heapq.heappop(self._reorder)[2], seq, calls, causes)

    # -- publication ----------------------------------------------------------------
    def _stamp(self, e: Estimate, age: float, stale: bool) -> Estimate:
        values = dict(e.values)
        values["stale"] = stale
        values["age"] = age
        return Estimate(self.name, self.name, e.t, values, self.kind)

    def _publish(self, e: Estimate, cause: int) -> None:
        self.health.count("estimates")
        self.router.publish(e, cause)

    def _apply(self, calls: list[Call], results: list[list[Any]], causes: list[int]) -> None:
        """What the core returned, in call order: published, held or marked stale."""
        decimate = self.publish_rate > 0
        steps = 0
        last_in = self._last_input_t
        for (what, arg), out, cause in zip(calls, results, causes):
            if what == "step":
                steps += 1
                if last_in is None or arg.t > last_in:
                    last_in = arg.t
                if not out and not self._stale:  # most steps: nothing to publish
                    continue
                self._last_input_t = last_in
                if self._stale:
                    self._stale = False
                    self.health.set_state("running", "inputs back")
                for e in out:
                    e = self._stamp(e, max(0.0, e.t - self._last_input_t), False)
                    self._last = e
                    if decimate:
                        self._held = e
                    else:
                        self._publish(e, cause)
                continue
            # A tick of the data-time grid at `arg`.
            self._last_input_t = last_in
            for e in out:
                age = 0.0 if self._last_input_t is None else max(0.0, arg - self._last_input_t)
                e = self._stamp(e, age, False)
                self._last = e
                self._publish(e, cause)
            if self._held is not None:
                self._publish(self._held, cause)
                self._held = None
            last_in = self._last_input_t
            if self.stale_after > 0 and last_in is not None and arg - last_in > self.stale_after:
                if not self._stale:
                    self._stale = True
                    self.health.set_state("stale", f"no input for {arg - last_in:.1f} s of data")
                    self.health.count("stale_periods")
                last = self._last
                if last is not None:
                    values = dict(last.values)
                    values["stale"] = True
                    values["age"] = arg - last_in
                    self._publish(Estimate(self.name, self.name, arg, values, self.kind), cause)
            self.health.info["age"] = None if last_in is None else max(0.0, arg - last_in)
        self._last_input_t = last_in
        if steps:
            self.health.count("steps", steps)

    # -- the worker's life ----------------------------------------------------------
    @property
    def backlog(self) -> int:
        """Inputs received and not stepped yet (queued or waiting for their turn)."""
        return len(self.sub.queue) + len(self._pending)

    async def _work(self, items: list[tuple[int, Any]], final: bool = False) -> None:
        self._take(items)
        bound = self.bound()
        queue = self.sub.queue
        if len(queue):
            # Still queued (the batch was cut to keep the backlog bounded): nothing at
            # or above the oldest number among them is complete yet.
            oldest = min((seq for seq, rec in queue if rec is not None), default=bound + 1)
            if oldest <= bound:
                bound = oldest - 1
        calls: list[Call] = []
        causes: list[int] = []
        pending = self._pending
        pop = pending.popleft
        limit = self.runner.max_calls
        # `_admit` inlined for the common input (a record stepped as it comes, no
        # reorder window): the same calls, a few µs less per record at a replay's rate
        direct = self.window <= 0.0
        tick_at = self._tick_at()
        append_call, append_cause = calls.append, causes.append
        while pending and pending[0][0] <= bound and len(calls) < limit:
            seq, _, _, rec = pop()
            if not direct or rec.__class__ is HealthRecord:
                self._admit(seq, rec, calls, causes)
                tick_at = self._tick_at()
                continue
            t = rec.t
            if t < self._stepped:
                self._late()
                continue
            if t >= tick_at:
                self._tick_to(t, seq, calls, causes)
                tick_at = self._tick_at()
            if t > self._stepped:
                self._stepped = t
            append_call(("step", rec))
            append_cause(seq)
        more = bool(pending) and pending[0][0] <= bound
        if final and not more:
            self._flush_reorder(bound, calls, causes)
        if not more:
            done_after = bound
        else:
            # Everything numbered below the next pending record is done.
            done_after = max(self._done, min(bound, pending[0][0] - 1))
        if calls:
            self._busy = True
            # (a process runner starts the exchange at once, in its helper thread)
            if self.depth > 1:
                call: asyncio.Future[list[list[Any]]] = asyncio.ensure_future(self.runner.call(calls))
            else:  # in the loop: called here and now, as a future already done
                call = asyncio.get_running_loop().create_future()
                try:
                    call.set_result(await self.runner.call(calls))
                except CoreFailed as exc:
                    call.set_exception(exc)
            self._inflight.append((call, calls, causes, done_after))
            # a batch to a process: the next one goes before this one's answer is
            # applied (the child has it to hand when it is done with this one); at most
            # `depth` on their way, and all of them applied when there is no more to do
            while self._inflight and (len(self._inflight) > self.depth - 1 or final
                                      or not (more or len(queue))):
                await self._apply_oldest()
        else:
            while self._inflight:
                await self._apply_oldest()
            self._done = done_after
        if more:
            self.wake()  # the rest of what is ready, in the next batch
        if not calls:
            for d in self.downstream:
                d.wake()

    async def _apply_oldest(self) -> None:
        """Await the oldest batch on its way, publish what it made, move the watermark."""
        call, calls, causes, done_after = self._inflight[0]
        try:
            try:
                results = await call
            except CoreFailed as exc:
                self._failures += 1
                self._inflight.popleft()
                self._apply(calls[: len(exc.results)], exc.results, causes)
                # the call that failed and every one after it, and the batches sent after it
                lost = sum(1 for what, _ in calls[len(exc.results) :] if what == "step")
                lost += await self._drop_inflight()
                if lost:
                    self.health.count("dropped.core_failure", lost)
                raise
            self._inflight.popleft()
            self._apply(calls, results, causes)
            self._failures = 0
            self._done = done_after
        finally:
            self._busy = bool(self._inflight)
        for d in self.downstream:
            d.wake()

    async def _drop_inflight(self) -> int:
        """After a failure: the batches still on their way are waited for (their
        answers belong to the core that failed) and their steps counted as lost."""
        lost = 0
        while self._inflight:
            call, calls, _, _ = self._inflight.popleft()
            try:
                await call
            except Exception:  # (it failed too, or the process is gone: lost either way)
                pass
            lost += sum(1 for what, _ in calls if what == "step")
        return lost

    async def run(self) -> None:
        """Feed the core until cancelled or, after `finish()`, until all is done."""
        if self.give_up_after is not None and self._failures >= self.give_up_after:
            await self._given_up()
            return
        self.health.set_state("starting")
        try:
            await self.runner.start()
        except Exception:
            self._failures += 1  # a core that cannot even start fails like one that raises
            raise
        self.health.set_state("running")
        get = self.sub.queue.get_batch
        queue = self.sub.queue
        room = queue.maxsize
        in_loop = self.runner.placement == "loop"
        while True:
            if self._closing and not len(queue):
                if self._pending and self._pending[0][0] > self.bound():
                    self._take(await get())  # an upstream worker is still finishing
                    continue
                await self._work([], final=True)
                self._progressed()
                if not self._pending and not len(queue):
                    return
                continue
            # Take what is queued, as far as the backlog stays within the queue's size.
            await self._work(await get(max(1, room - len(self._pending))))
            self._progressed()
            if in_loop:
                await asyncio.sleep(0)  # a batch stepped in the loop: let the inputs run

    async def _given_up(self) -> None:
        """No core any more: what arrives is counted as dropped, and nothing waits on
        this worker (downstream workers, the replay's back-pressure)."""
        self.gave_up = True
        self._finished = True
        self.health.set_state("failed", f"gave up after {self._failures} failures in a row")
        lost = sum(1 for *_, rec in self._pending if _is_input(rec)) + len(self._reorder)
        self._pending.clear()
        self._reorder.clear()
        for d in self.downstream:
            d.wake()
        get = self.sub.queue.get_batch
        while True:
            if lost:
                self.health.count("dropped.core_failure", lost)
            if self._closing and not len(self.sub.queue):
                return
            lost = sum(1 for _, rec in await get(1 << 30) if _is_input(rec))
            self._progressed()

    def progress(self) -> "asyncio.Future[None]":
        """Resolved when this worker has next taken a batch from its backlog: what a
        replay waiting for room awaits, instead of polling the loop while a worker
        in its own process works (the poll held the GIL its helper thread needed)."""
        f = self._progress
        if f is None or f.done():
            f = self._progress = asyncio.get_running_loop().create_future()
        return f

    def _progressed(self) -> None:
        f, self._progress = self._progress, None
        if f is not None and not f.done():
            f.set_result(None)

    def restart(self) -> None:
        """After a failure: a fresh core next time `run()` starts (inputs kept)."""
        self._held = None
        if self._inflight:  # on their way when the worker was stopped: lost with its core
            lost = sum(1 for _, calls, _, _ in self._inflight for what, _ in calls if what == "step")
            for call, *_ in self._inflight:
                call.cancel()
            self._inflight.clear()
            self._busy = False
            if lost:
                self.health.count("dropped.core_failure", lost)
        if self._reorder:  # held for the old core's time order: counted, not replayed
            self.health.count("dropped.core_failure", len(self._reorder))
            self._reorder.clear()

    async def on_restart(self) -> None:
        self.restart()
        await self.runner.stop()

    async def finish(self, timeout: float, patient: bool = False) -> None:
        """Step everything queued, release the reorder window, stop the core. Once:
        a replay finishes its workers at its end, and its runtime's stop() asks again.

        `patient` (a replay's end): the `timeout` is for a core that makes no progress;
        as long as it steps something within each `timeout`, it is waited for, however
        long the queue takes. A loaded machine made `test_real_logs[plaka]` lose 128
        inputs at a replay's end (issue 32): a replay must step every record."""
        if self._finish_ran:
            return
        self._finish_ran = True
        self._closing = True
        self.wake()
        task = self.task
        if task is not None and not task.done():
            if self.health.state == "backoff":
                task.cancel()  # waiting to restart: nothing will step it again
            while True:
                steps = self.health.counters.get("steps", 0)
                done, _ = await asyncio.wait([task], timeout=timeout)
                if done or not patient:
                    break
                if self.health.counters.get("steps", 0) == steps and self.health.state != "starting":
                    break  # neither stepping nor starting its process: given up on
            if not done:
                task.cancel()
                log.error("event=stop-timeout worker=%s reason='did not finish within %g s'", self.name, timeout)
                if isinstance(self.runner, ProcessRunner):
                    self.runner.kill_now()  # the helper thread may be waiting on it
                await asyncio.wait([task], timeout=1.0)
        rest = (
            sum(1 for _, rec in self.sub.queue if _is_input(rec))
            + sum(1 for *_, rec in self._pending if _is_input(rec))
            + len(self._reorder)
        )
        if self._held is not None:  # decimated, not yet published: the last word
            self._publish(self._held, self.router.seq)
            self._held = None
        # Whatever happened, nothing more comes from this worker: downstream stops waiting.
        self._finished = True
        for d in self.downstream:
            d.wake()
        if rest:
            self.health.count("dropped.shutdown", rest)
        try:
            await self.runner.stop()
        except Exception as exc:
            self.health.error(f"stop: {type(exc).__name__}: {exc}")
        if isinstance(self.runner, ProcessRunner):
            self.runner.close()
        if self.gave_up:
            self.health.set_state("failed", "gave up")

    def report(self) -> None:
        """Health snapshot time: the core's own report and the plugin's status."""
        info = self.health.info
        core = self.runner.report()
        if core:
            info["filter"] = core
            # A core that runs but knows it is wrong (a sensor left out, innovations far
            # outside their band) says so in `problems`: the worker is then not ok.
            problems = core.get("problems")
            self.health.set_problems(problems if isinstance(problems, list) else [])
        extra = self.plugin.status()
        if extra:
            info.update(extra)
        info["stale"] = self._stale
        info["queue"] = len(self.sub.queue)
        if isinstance(self.runner, ProcessRunner):
            info["pid"] = self.runner.pid
