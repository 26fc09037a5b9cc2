"""The runtime: builds plugins from the configuration and runs them in isolation.

Inputs, estimator workers and outputs each run under `supervise()`: one that raises
is restarted with backoff and reported in health while the others keep running.
Shutdown (SIGTERM/SIGINT) stops the inputs first, lets workers and outputs take what
is still queued, then flushes and closes the outputs within `shutdown_timeout`.

Estimator workers (`edged.workers`) run the same way live and in replay: behind
their queues, each in the event loop or in a process of its own, their inputs put into
one order that depends only on the data, so that estimates feeding other estimators
(STW into draft) arrive in the same order at any replay speed: the same log gives the
same output, bit for bit.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from .clock import Clock
from .config import Config, ConfigError
from .health import ComponentHealth, HealthRegistry
from .outputhost import OutputHost
from .plugin import InputPlugin, PluginContext, own_marks_of
from .records import HealthRecord
from .registry import Registry
from .router import Router
from .supervisor import RestartPolicy, Sleep, supervise
from .workers import WorkerHost

log = logging.getLogger("edged.runtime")


#: Failures in a row after which a replay's worker gives up (its inputs then counted as
#: dropped, the replay exits 1): a core that fails on every record must not hold it.
REPLAY_GIVE_UP = 20


class PluginBuildError(RuntimeError):
    """A plugin could not be constructed (names the plugin)."""


class InputHost:
    def __init__(self, name: str, plugin: InputPlugin, health: ComponentHealth) -> None:
        self.name = name
        self.plugin = plugin
        self.health = health

    async def run(self) -> None:
        await self.plugin.run()


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
        #: Plugins may behave differently in replay (a publisher blocks on a full link
        #: instead of dropping, since nobody waits on a replay in real time).
        self.options.setdefault("replay", replay)
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
                ctx.decoder = cls.make_decoder(name, cfg, health, self.own_marks)
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
                ordered = self.replay and plugin.ordered
                self.outputs.append(OutputHost(name, plugin, self.router, health, self.clock, ordered=ordered))
        #: What the outputs' own traffic carries: every decoder refuses it.
        self.own_marks = own_marks_of((type(o.plugin.plugin), o.plugin.plugin.config) for o in self.outputs)
        hosts: dict[str, WorkerHost] = {}
        for name, c in cfg.estimators.items():
            if c.enabled:
                plugin, health, _ = self._make("estimators", name, c)
                try:
                    hosts[name] = WorkerHost(name, plugin, self.router, health)
                except Exception as exc:
                    raise PluginBuildError(f"estimators.{name}: {type(exc).__name__}: {exc}") from exc
        self.workers = self._link_workers(hosts)
        configured = frozenset(cfg.estimators)
        for out in self.outputs:
            try:
                out.plugin.plugin.check_estimators(configured)
            except ValueError as exc:
                self._config_errors.append((f"outputs.{out.name}", str(exc)))
            keys = out.plugin.plugin.keys or frozenset()
            out.link([w for w in self.workers if f"est/{w.name}" in keys])
        if not self.replay:
            for name, c in cfg.inputs.items():
                if c.enabled:
                    plugin, health, _ = self._make("inputs", name, c)
                    self.inputs.append(InputHost(name, plugin, health))

    def _link_workers(self, hosts: dict[str, WorkerHost]) -> list[WorkerHost]:
        """The workers in topological order (an estimator after those it consumes),
        each linked to its upstream; a consumed estimate no instance makes, or a cycle,
        is a configuration error naming the table."""
        deps: dict[str, list[str]] = {}
        for name, host in hosts.items():
            deps[name] = []
            for key in sorted(host.inputs):
                if not key.startswith("est/"):
                    continue
                up = key[4:]
                if up in hosts:
                    deps[name].append(up)
                elif up in self.config.estimators:
                    log.warning("event=input-disabled estimator=%s consumes=%s reason='that estimator is disabled'", name, key)
                else:
                    known = ", ".join(n for n in hosts if n != name) or "none"
                    self._config_errors.append(
                        (f"estimators.{name}", f"consumes {key}, but no estimator instance is named {up!r} (configured: {known})")
                    )
        order: list[str] = []
        state: dict[str, int] = {}  # 1 visiting, 2 done

        def visit(n: str, path: list[str]) -> None:
            if state.get(n) == 2:
                return
            if state.get(n) == 1:
                cycle = " -> ".join(path[path.index(n):] + [n])
                self._config_errors.append((f"estimators.{n}", f"estimators consume each other in a cycle: {cycle}"))
                return
            state[n] = 1
            for d in deps[n]:
                visit(d, path + [n])
            state[n] = 2
            order.append(n)

        for n in hosts:
            visit(n, [])
        for rank, n in enumerate(order):
            hosts[n].link([hosts[d] for d in deps[n]], rank)
        return [hosts[n] for n in order]

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
        # Workers run behind their queues live and in replay alike. A replay restarts a
        # failed core at once: its backoff would only stall the data, not spare a peer.
        worker_sleep = _no_wait if self.replay else self.sleep
        for w in self.workers:
            if self.replay:
                w.give_up_after = REPLAY_GIVE_UP
            self._spawn(
                supervise(w.run, w.health, self.clock, policy=self.restart, sleep=worker_sleep, on_restart=w.on_restart),
                f"estimator:{w.name}",
            )
            w.task = self._tasks[-1]
        if not self.replay:
            for i in self.inputs:
                self._spawn(
                    supervise(i.run, i.health, self.clock, policy=self.restart, sleep=self.sleep),
                    f"input:{i.name}",
                )
            self._ticker = asyncio.get_running_loop().create_task(self._tick_loop(), name="health")
        # Let every task reach its first await (outputs open their files/sessions).
        await asyncio.sleep(0)

    def ended_tasks(self) -> list[str]:
        """The supervised tasks (inputs, workers, outputs, the health ticker) that have
        ended while the runtime runs: none should, so the systemd watchdog is withheld."""
        tasks = [*self._tasks, *([self._ticker] if self._ticker is not None else [])]
        return [t.get_name() for t in tasks if t.done()]

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
        for host in (*self.inputs, *self.outputs):
            try:
                extra = host.plugin.status()
            except Exception as exc:  # a plugin's report must not stop the snapshot
                host.health.error(f"status: {type(exc).__name__}: {exc}")
                continue
            if extra:
                host.health.info.update(extra)
        for w in self.workers:
            try:
                w.report()
            except Exception as exc:
                w.health.error(f"status: {type(exc).__name__}: {exc}")
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
        await self.finish_workers()
        for w in self.workers:
            w.health.set_state("stopped")
        output_tasks = [t for t in other if t.get_name().startswith("output:")]
        await self._cancel(output_tasks)
        timeout = self.config.edged.shutdown_timeout
        for out in self.outputs:
            try:
                await asyncio.wait_for(out.drain_and_close(), timeout)
            except (asyncio.TimeoutError, Exception) as exc:
                out.health.error(f"close: {type(exc).__name__}: {exc}")
                out.plugin.kill_now()  # (a process must not outlive the daemon)
            out.health.set_state("stopped")
        self._tasks.clear()

    async def outputs_ready(self) -> None:
        """Wait (each within its own bound) until every output can deliver."""
        results = await asyncio.gather(*(o.plugin.ready() for o in self.outputs), return_exceptions=True)
        for out, ok in zip(self.outputs, results):
            if ok is not True:
                why = f"{type(ok).__name__}: {ok}" if isinstance(ok, BaseException) else "not linked in time"
                log.warning("event=output-not-ready output=%s reason=%r action='replaying anyway'", out.name, why)
                out.health.count("not_ready_at_start")

    async def finish_workers(self, patient: bool = False) -> None:
        """Let every worker step what is queued for it and release its reorder window,
        upstream before downstream, each within `shutdown_timeout`; `patient` (the end
        of a replay that ran to its end): as long as it makes progress, however long."""
        timeout = self.config.edged.shutdown_timeout
        for w in self.workers:
            await w.finish(timeout, patient=patient)

    def worker_backlog(self) -> int:
        """Largest backlog of a worker: replay waits on it instead of dropping."""
        return max((w.backlog for w in self.workers), default=0)

    async def worker_progress(self, limit: int, timeout: float) -> None:
        """Wait until a worker whose backlog is over `limit` has taken its next batch,
        or `timeout` seconds (a worker being restarted after a failure takes none)."""
        waits = [w.progress() for w in self.workers if w.backlog > limit]
        if waits:
            await asyncio.wait(waits, timeout=timeout)

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

    def outputs_blocked(self) -> bool:
        """An output in its own process is waiting for room: a replay waits with it,
        so that the output takes each stretch of records at the same data time as
        an output in the loop would."""
        return any(o.blocked for o in self.outputs)

    async def output_progress(self, limit: int, timeout: float) -> None:
        """Wait until an output whose queue is over `limit` has taken its next batch,
        or `timeout` seconds."""
        waits = [o.progress() for o in self.outputs if o.opened and (o.blocked or len(o.sub.queue) > limit)]
        if waits:
            await asyncio.wait(waits, timeout=timeout)



async def _no_wait(delay: float) -> None:
    await asyncio.sleep(0)
