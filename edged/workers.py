"""Estimator workers: one core each, fed in a deterministic order, live and in replay.

A `WorkerHost` puts together the parts of a worker, each with one job:

- `edged.ordering.InputOrder`: its inputs in one order that depends only on the data,
  stepped only up to what no other worker can still add to (its bound), and how far
  it is done (its watermark, which the workers it feeds wait on);
- `edged.datatime.CallPlan`: those inputs as calls in data time, the ticks of its
  grid between them, its reorder window;
- `edged.publication.Publication`: what is published of the core's results
  (decimation at `publish_rate`, `stale` marks);
- `edged.workerproc`: where the core runs, in the event loop or in a process of its
  own (the process host `edged.childproc`), with one interface.

The host itself runs the worker's life: batches of calls to the core (at most `depth`
on their way), failures and restarts, the end. A core that raises, dies or hangs
past the watchdog makes `run()` raise: the runtime's supervisor restarts it with
backoff and reports it.
"""

from __future__ import annotations

import asyncio
import collections
import logging
from typing import Any

from .datatime import CallPlan
from .health import ComponentHealth
from .ordering import InputOrder
from .plugin import EstimatorPlugin
from .publication import Publication
from .records import HealthRecord
from .router import Router
from .workerproc import CoreFailed, LoopRunner, ProcessRunner

__all__ = ["WorkerHost"]

log = logging.getLogger("edged.workers")

Call = tuple[str, Any]
#: A batch on its way to the core: (its answer, its calls, their causes, the
#: watermark once it is applied).
Batch = tuple["asyncio.Future[list[list[Any]]]", list[Call], list[int], int]


def _is_input(rec: Any) -> bool:
    """A record for the core (not a wake-up, not a health beacon): what a drop loses."""
    return rec is not None and rec.__class__ is not HealthRecord


def _steps(calls: list[Call]) -> int:
    return sum(1 for what, _ in calls if what == "step")


class WorkerHost:
    """Hosts one estimator core: orders its inputs, fires its ticks, publishes its
    estimates under the instance's name, marks them stale, reports its health."""

    def __init__(self, name: str, plugin: EstimatorPlugin, router: Router, health: ComponentHealth) -> None:
        self.name = name
        self.plugin = plugin
        self.router = router
        self.health = health
        cfg = plugin.config
        self.runner: LoopRunner | ProcessRunner = (
            ProcessRunner(plugin, name, cfg.watchdog) if cfg.worker == "process" else LoopRunner(plugin))
        # What the core consumes and whether it ticks: from its class and the
        # configuration (no core is made here for a process worker).
        self.inputs: frozenset[str] = plugin.inputs()
        sources = cfg.sources
        if sources is not None:  # upstream estimates and health beacons pass the filter
            sources = set(sources) | {k[4:] for k in self.inputs if k.startswith("est/")} | {HealthRecord.source}
        self.sub = router.subscribe(
            f"estimator:{name}", self.inputs | {HealthRecord.route_key}, maxsize=cfg.queue_size, health=health,
            sources=sources, preferred_only=cfg.preferred_only, reorder_window=None, sequenced=True,
        )
        self.order = InputOrder(router, self.sub.queue)
        self.plan = CallPlan(health, cfg.reorder_window, cfg.publish_rate,
                             cfg.publish_rate > 0 or cfg.stale_after > 0 or plugin.ticks())
        self.out = Publication(name, plugin.kind, router, health, cfg.publish_rate, cfg.stale_after)
        self.task: asyncio.Task[None] | None = None
        self._inflight: collections.deque[Batch] = collections.deque()
        self._progress: asyncio.Future[None] | None = None  # see progress()
        self._closing = False
        self._finish_ran = False
        #: Failures in a row after which the worker gives up (replay: a core that fails
        #: on every attempt would otherwise be restarted for ever and hold the replay);
        #: None: never (live, the supervisor's backoff spaces the attempts).
        self.give_up_after: int | None = None
        self._failures = 0
        self.gave_up = False
        health.info["placement"] = self.runner.placement
        health.info["inputs"] = sorted(self.inputs)

    # -- its place among the workers (edged.ordering) ---------------------------------
    def link(self, upstream: list["WorkerHost"], rank: int) -> None:
        """Set by the runtime once every worker exists: whose estimates this one
        consumes, and its place in the topological order."""
        self.order.link([u.order for u in upstream], [u.name for u in upstream], rank)

    def watermark(self) -> int:
        return self.order.watermark()

    def wake(self) -> None:
        self.order.wake()

    @property
    def backlog(self) -> int:
        """Inputs received and not stepped yet (queued or waiting for their turn)."""
        return len(self.sub.queue) + len(self.order.pending)

    # -- batches ----------------------------------------------------------------------
    async def _work(self, items: list[tuple[int, Any]], final: bool = False) -> None:
        order = self.order
        order.take(items)
        bound = order.ready_bound()
        calls: list[Call] = []
        causes: list[int] = []
        more = self.plan.admit_ready(order.pending, bound, self.runner.max_calls, calls, causes)
        if final and not more:
            self.plan.release(bound, calls, causes)
        done_after = order.done_after(bound, more)
        if calls:
            await self._send(calls, causes, done_after, final, more)
        else:
            while self._inflight:
                await self._apply_oldest()
            order.done = done_after
        if more:
            order.wake()  # the rest of what is ready, in the next batch
        if not calls:
            order.wake_downstream()

    async def _send(self, calls: list[Call], causes: list[int], done_after: int, final: bool, more: bool) -> None:
        """The batch to the core. In a process it goes at once, and the next one goes
        before this one's answer is applied (the child has it to hand when it is done
        with this one): at most `depth` on their way, all applied when there is no more
        to do. In the loop: called here and now, as a future already done."""
        self.order.busy = True
        runner = self.runner
        if runner.depth > 1:
            call: asyncio.Future[list[list[Any]]] = asyncio.ensure_future(runner.call(calls))
        else:
            call = asyncio.get_running_loop().create_future()
            try:
                call.set_result(await runner.call(calls))
            except CoreFailed as exc:
                call.set_exception(exc)
        self._inflight.append((call, calls, causes, done_after))
        queue = self.sub.queue
        while self._inflight and (len(self._inflight) > runner.depth - 1 or final or not (more or len(queue))):
            await self._apply_oldest()

    async def _apply_oldest(self) -> None:
        """Await the oldest batch on its way, publish what it made, move the watermark."""
        call, calls, causes, done_after = self._inflight[0]
        try:
            try:
                results = await call
            except CoreFailed as exc:
                self._failures += 1
                self._inflight.popleft()
                self.out.apply(calls[: len(exc.results)], exc.results, causes)
                # the call that failed and every one after it, and the batches sent after it
                lost = _steps(calls[len(exc.results) :]) + await self._drop_inflight()
                if lost:
                    self.health.count("dropped.core_failure", lost)
                raise
            self._inflight.popleft()
            self.out.apply(calls, results, causes)
            self._failures = 0
            self.order.done = done_after
        finally:
            self.order.busy = bool(self._inflight)
        self.order.wake_downstream()

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
            lost += _steps(calls)
        return lost

    # -- the worker's life ------------------------------------------------------------
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
        queue = self.sub.queue
        get = queue.get_batch
        order = self.order
        in_loop = self.runner.placement == "loop"
        while True:
            if self._closing and not len(queue):
                if order.pending and order.pending[0][0] > order.bound():
                    order.take(await get())  # an upstream worker is still finishing
                    continue
                await self._work([], final=True)
                self._progressed()
                if not order.pending and not len(queue):
                    return
                continue
            # Take what is queued, as far as the backlog stays within the queue's size.
            await self._work(await get(max(1, queue.maxsize - len(order.pending))))
            self._progressed()
            if in_loop:
                await asyncio.sleep(0)  # a batch stepped in the loop: let the inputs run

    async def _given_up(self) -> None:
        """No core any more: what arrives is counted as dropped, and nothing waits on
        this worker (downstream workers, the replay's back-pressure)."""
        self.gave_up = True
        self.order.finished = True
        self.health.set_state("failed", f"gave up after {self._failures} failures in a row")
        lost = sum(1 for *_, rec in self.order.pending if _is_input(rec)) + self.plan.drop_held()
        self.order.pending.clear()
        self.order.wake_downstream()
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
        in its own process works (the poll held the GIL its process needed)."""
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
        self.out.held = None
        if self._inflight:  # on their way when the worker was stopped: lost with its core
            lost = sum(_steps(calls) for _, calls, _, _ in self._inflight)
            for call, *_ in self._inflight:
                call.cancel()
            self._inflight.clear()
            self.order.busy = False
            if lost:
                self.health.count("dropped.core_failure", lost)
        held = self.plan.drop_held()  # held for the old core's time order: counted, not replayed
        if held:
            self.health.count("dropped.core_failure", held)

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
        await self._wait_done(timeout, patient)
        rest = (sum(1 for _, rec in self.sub.queue if _is_input(rec))
                + sum(1 for *_, rec in self.order.pending if _is_input(rec)) + len(self.plan.reorder))
        self.out.publish_held(self.router.seq)  # decimated, not yet published: the last word
        # Whatever happened, nothing more comes from this worker: downstream stops waiting.
        self.order.finished = True
        self.order.wake_downstream()
        if rest:
            self.health.count("dropped.shutdown", rest)
        try:
            await self.runner.stop()
        except Exception as exc:
            self.health.error(f"stop: {type(exc).__name__}: {exc}")
        self.runner.close()
        if self.gave_up:
            self.health.set_state("failed", "gave up")

    async def _wait_done(self, timeout: float, patient: bool) -> None:
        """Let the task step what is queued (see `finish`); one that does not end in
        time is cancelled, and its core's process killed."""
        task = self.task
        if task is None or task.done():
            return
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
            self.runner.kill_now()  # a batch on its way may be waiting on it
            await asyncio.wait([task], timeout=1.0)

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
        info["stale"] = self.out.stale
        info["queue"] = len(self.sub.queue)
        info.update(self.runner.info())
