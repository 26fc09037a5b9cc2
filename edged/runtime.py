"""The runtime: builds plugins from the configuration and runs them in isolation.

Inputs, estimator workers and outputs each run under `supervise()`: one that raises
is restarted with backoff and reported in health while the others keep running.
Shutdown (SIGTERM/SIGINT) stops the inputs first, lets workers and outputs take what
is still queued, then flushes and closes the outputs within `shutdown_timeout`.

In replay the estimator workers run inline (in the publisher's stack) rather than
behind queues, so that estimates feeding other estimators (STW into draft) arrive in
the same order at any replay speed: the same log gives the same output, bit for bit.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import logging
from typing import Any

from .clock import Clock
from .config import Config, ConfigError
from .health import ComponentHealth, HealthRegistry
from .plugin import (
    EstimatorCore,
    EstimatorPlugin,
    InputPlugin,
    OutputPlugin,
    PluginContext,
)
from .records import HealthRecord
from .registry import Registry
from .router import Router, Subscription
from .supervisor import RestartPolicy, Sleep, supervise

log = logging.getLogger("edged.runtime")


class PluginBuildError(RuntimeError):
    """A plugin could not be constructed (names the plugin)."""


class InputHost:
    def __init__(self, name: str, plugin: InputPlugin, health: ComponentHealth) -> None:
        self.name = name
        self.plugin = plugin
        self.health = health

    async def run(self) -> None:
        await self.plugin.run()


class WorkerHost:
    """Hosts one estimator core: feeds it in time order, restarts it when it fails."""

    def __init__(
        self,
        name: str,
        plugin: EstimatorPlugin,
        router: Router,
        health: ComponentHealth,
        *,
        inline: bool,
    ) -> None:
        self.name = name
        self.plugin = plugin
        self.router = router
        self.health = health
        self.inline = inline
        cfg = plugin.config
        self.window: float = float(getattr(cfg, "reorder_window", 0.0))
        self.core: EstimatorCore = plugin.make_core()
        self._heap: list[tuple[float, int, Any]] = []
        self._seq = itertools.count()
        self._newest = float("-inf")
        sources = getattr(cfg, "sources", None)
        self.sub: Subscription = router.subscribe(
            f"estimator:{name}",
            self.core.inputs,
            maxsize=int(getattr(cfg, "queue_size", 10_000)),
            health=health,
            sources=sources,
            preferred_only=True,
            reorder_window=self.window,
            handler=self._feed_inline if inline else None,
        )
        if inline:
            health.set_state("running")

    def _step(self, rec: Any) -> None:
        estimates = self.core.step(rec)
        self.health.count("steps")
        for e in estimates:
            self.health.count("estimates")
            self.router.publish(e)

    def feed(self, rec: Any) -> None:
        """Pass `rec` on in time order (buffered within the reorder window)."""
        if self.window <= 0.0:
            self._step(rec)
            return
        heapq.heappush(self._heap, (rec.t, next(self._seq), rec))
        if rec.t > self._newest:
            self._newest = rec.t
        horizon = self._newest - self.window
        heap = self._heap
        while heap and heap[0][0] <= horizon:
            self._step(heapq.heappop(heap)[2])

    def flush(self) -> None:
        """Release what the reorder window still holds (shutdown, end of replay)."""
        while self._heap:
            self._step(heapq.heappop(self._heap)[2])

    def _feed_inline(self, rec: Any) -> None:
        try:
            self.feed(rec)
        except Exception as exc:  # isolate: a failing core must not stop the replay
            self.health.error(f"{type(exc).__name__}: {exc}")
            self.health.restarts += 1
            self.restart()

    def restart(self) -> None:
        self.core = self.plugin.make_core()
        self._heap.clear()

    async def run(self) -> None:
        get = self.sub.queue.get_batch
        while True:
            for rec in await get():
                self.feed(rec)

    def drain(self) -> None:
        for rec in self.sub.queue.drain_nowait():
            self.feed(rec)
        self.flush()


class OutputHost:
    def __init__(self, name: str, plugin: OutputPlugin, router: Router, health: ComponentHealth) -> None:
        self.name = name
        self.plugin = plugin
        self.health = health
        self.opened = False
        keys = plugin.keys
        self.sub = router.subscribe(
            f"output:{name}",
            keys,
            exclude=plugin.exclude_keys,
            maxsize=int(getattr(plugin.config, "queue_size", 100_000)),
            health=health,
            preferred_only=False,
            reorder_window=None,
        )

    async def run(self) -> None:
        await self.plugin.open()
        self.opened = True
        get = self.sub.queue.get_batch
        write = self.plugin.write
        while True:
            batch = await get()
            write(batch)
            self.health.count("written", len(batch))

    async def close(self) -> None:
        if self.opened:
            self.opened = False
            await self.plugin.close()

    def flush(self) -> None:
        if self.opened:
            try:
                self.plugin.flush()
            except Exception as exc:
                self.health.error(f"flush: {type(exc).__name__}: {exc}")

    async def drain_and_close(self) -> None:
        if self.opened:
            rest = self.sub.queue.drain_nowait()
            if rest:
                try:
                    self.plugin.write(rest)
                    self.health.count("written", len(rest))
                except Exception as exc:
                    self.health.error(f"final write: {type(exc).__name__}: {exc}")
            self.flush()
        await self.close()


class Runtime:
    """One daemon's (or one replay's) set of plugins, router, clock and health."""

    def __init__(
        self,
        config: Config,
        registry: Registry,
        clock: Clock,
        *,
        replay: bool = False,
        options: dict[str, Any] | None = None,
        restart: RestartPolicy = RestartPolicy(),
        sleep: Sleep = asyncio.sleep,
    ) -> None:
        self.config = config
        self.registry = registry
        self.clock = clock
        self.replay = replay
        self.options = dict(options or {})
        self.options.setdefault("config_text", config.text)
        self.restart = restart
        self.sleep = sleep
        self.health = HealthRegistry(clock)
        self.router = Router(self.health.component("router", "core", "router"))
        for kind, sources in config.router.priority.items():
            self.router.set_priority(kind, sources, config.router.failover_timeout)
        self.inputs: list[InputHost] = []
        self.workers: list[WorkerHost] = []
        self.outputs: list[OutputHost] = []
        self._tasks: list[asyncio.Task[None]] = []
        self._ticker: asyncio.Task[None] | None = None
        self._config_errors: list[tuple[str, str]] = []
        self._build()
        if self._config_errors:
            raise ConfigError(str(config.path or "<configuration>"), self._config_errors)

    # -- construction ---------------------------------------------------------
    def _context(self, name: str, health: ComponentHealth) -> PluginContext:
        return PluginContext(
            name=name,
            clock=self.clock,
            health=health,
            publish=self.router.publish,
            vessel_id=self.config.edged.vessel_id,
            config_dir=self.config.config_dir,
            options=self.options,
        )

    def _make(self, role: str, name: str, cfg: Any) -> tuple[Any, ComponentHealth, PluginContext]:
        cls = self.registry.get(role, cfg.type)
        health = self.health.component(name, role[:-1], cfg.type)
        ctx = self._context(name, health)
        if role == "inputs" and getattr(cls, "protocol", ""):
            try:
                ctx.decoder = cls.make_decoder(name, cfg, health)
            except NotImplementedError:
                ctx.decoder = None
        try:
            plugin = cls(cfg, ctx)
        except Exception as exc:
            raise PluginBuildError(f"{role}.{name} (type {cfg.type}): {type(exc).__name__}: {exc}") from exc
        try:
            plugin.check()
        except ValueError as exc:
            self._config_errors.append((f"{role}.{name}", str(exc)))
        return plugin, health, ctx

    def _build(self) -> None:
        cfg = self.config
        # Outputs first: they must see the first record an input or worker publishes.
        for name, c in cfg.outputs.items():
            if c.enabled:
                plugin, health, _ = self._make("outputs", name, c)
                self.outputs.append(OutputHost(name, plugin, self.router, health))
        for name, c in cfg.estimators.items():
            if c.enabled:
                plugin, health, _ = self._make("estimators", name, c)
                try:
                    host = WorkerHost(name, plugin, self.router, health, inline=self.replay)
                except Exception as exc:
                    raise PluginBuildError(f"estimators.{name}: {type(exc).__name__}: {exc}") from exc
                self.workers.append(host)
        if not self.replay:
            for name, c in cfg.inputs.items():
                if c.enabled:
                    plugin, health, _ = self._make("inputs", name, c)
                    self.inputs.append(InputHost(name, plugin, health))

    # -- lifecycle ------------------------------------------------------------
    def _spawn(self, coro: Any, name: str) -> None:
        self._tasks.append(asyncio.get_running_loop().create_task(coro, name=name))

    async def start(self) -> None:
        self.router.health.set_state("running")  # type: ignore[union-attr]
        for out in self.outputs:

            async def _cleanup(o: OutputHost = out) -> None:
                await o.close()

            self._spawn(
                supervise(out.run, out.health, self.clock, policy=self.restart, sleep=self.sleep, on_restart=_cleanup),
                f"output:{out.name}",
            )
        if not self.replay:
            for w in self.workers:

                async def _restart(wh: WorkerHost = w) -> None:
                    wh.restart()

                self._spawn(
                    supervise(w.run, w.health, self.clock, policy=self.restart, sleep=self.sleep, on_restart=_restart),
                    f"estimator:{w.name}",
                )
            for i in self.inputs:
                self._spawn(
                    supervise(i.run, i.health, self.clock, policy=self.restart, sleep=self.sleep),
                    f"input:{i.name}",
                )
            self._ticker = asyncio.get_running_loop().create_task(self._tick_loop(), name="health")
        # Let every task reach its first await (outputs open their files/sessions).
        await asyncio.sleep(0)

    async def _tick_loop(self) -> None:
        interval = self.config.edged.health_interval
        while True:
            await asyncio.sleep(interval)  # wall time on purpose: health is about now
            self.tick()

    def tick(self, flush: bool = True) -> None:
        """Publish a health snapshot and flush the outputs (1 Hz).

        Replay ticks once per second of data, hundreds of times per wall second when
        it runs fast; it asks for the flush (a chunk closed and fsynced) only about
        once per wall second, which is what the flush is for.
        """
        snap = self.health_snapshot()
        self.router.publish(HealthRecord(snap["t"], snap))
        if flush:
            for out in self.outputs:
                out.flush()

    def health_snapshot(self) -> dict[str, Any]:
        for host in self.outputs:
            extra = host.plugin.status()
            if extra:
                host.health.info.update(extra)
        self.health.component("router", "core").info.update(self.router.stats())
        snap = self.health.snapshot()
        snap["vessel_id"] = self.config.edged.vessel_id
        return snap

    def rotate(self) -> None:
        """SIGHUP: start new recording files."""
        for out in self.outputs:
            if out.opened:
                try:
                    out.plugin.rotate()
                except Exception as exc:
                    out.health.error(f"rotate: {type(exc).__name__}: {exc}")

    async def stop(self) -> None:
        """Stop inputs, drain workers and outputs, flush and close within the timeout."""
        if self._ticker is not None:
            self._ticker.cancel()
        input_tasks = [t for t in self._tasks if t.get_name().startswith("input:")]
        other = [t for t in self._tasks if t not in input_tasks]
        await self._cancel(input_tasks)
        for i in self.inputs:
            i.health.set_state("stopped")
        worker_tasks = [t for t in other if t.get_name().startswith("estimator:")]
        await self._cancel(worker_tasks)
        for w in self.workers:
            try:
                w.drain()
            except Exception as exc:
                w.health.error(f"drain: {type(exc).__name__}: {exc}")
            w.health.set_state("stopped")
        output_tasks = [t for t in other if t.get_name().startswith("output:")]
        await self._cancel(output_tasks)
        timeout = self.config.edged.shutdown_timeout
        for out in self.outputs:
            try:
                await asyncio.wait_for(out.drain_and_close(), timeout)
            except (asyncio.TimeoutError, Exception) as exc:
                out.health.error(f"close: {type(exc).__name__}: {exc}")
            out.health.set_state("stopped")
        self._tasks.clear()

    async def _cancel(self, tasks: list[asyncio.Task[None]]) -> None:
        """Cancel and wait, bounded: a plugin that ignores cancellation is left behind."""
        for t in tasks:
            t.cancel()
        if not tasks:
            return
        _, pending = await asyncio.wait(tasks, timeout=self.config.edged.shutdown_timeout)
        for t in pending:
            log.error("event=stop-timeout task=%s reason='did not stop when cancelled'", t.get_name())

    def output_backlog(self) -> int:
        """Largest queue of a running output: replay waits on it instead of dropping."""
        return max((len(o.sub.queue) for o in self.outputs if o.opened), default=0)

