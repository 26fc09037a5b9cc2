"""Where an estimator's core runs (its *placement*): in the event loop (`LoopRunner`) or
in a process of its own (`ProcessRunner`, through the process host `edged.childproc`).

Both take a batch of calls, `[("step", record) | ("tick", t), ...]`, and return, per
call, the estimates the core made; a core that raises, dies or hangs past the watchdog
makes `call` raise `CoreFailed` with the results of the calls before it. The worker
host (`edged.workers`) never asks which placement it has: `depth` says how many
batches it may have on their way at once, `max_calls` how large one may be.

In the child, the core is made from the plugin's class and configuration
(`make_core_servant`), so that it need not be picklable itself; records and
estimates are.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .childmain import CallFailed
from .childproc import ChildDied, ChildProcess, forget
from .estimator import Estimator
from .health import ComponentHealth
from .plugin import EstimatorPlugin, PluginContext
from .signals import StopRequested, step as core_step

__all__ = ["LoopRunner", "ProcessRunner", "CoreFailed", "MAX_CALLS", "MAX_CALLS_PROCESS", "CHUNK_PROCESS",
           "run_calls", "core_health"]

#: Calls made in one batch: in the loop, between two chances for the inputs to run; to
#: a process, per batch (preparing one and applying the last one's answers, back to
#: back when the worker is saturated, hold the loop for about 1.2 ms per 512 calls
#: each: 1024 made a 5-ms stall), sent as messages of CHUNK_PROCESS calls (pickling
#: one holds the interpreter: 256 calls cost about 0.3 ms each way).
MAX_CALLS = 1024
MAX_CALLS_PROCESS = 512
#: Calls per message to a process: the child has the next message to hand when it is
#: done with one (one message at a time, it sat idle while its answer travelled back
#: and the loop got round to it: half the time, with the draft estimator's 600
#: readings a second).
CHUNK_PROCESS = 256

Call = tuple[str, Any]


class CoreFailed(RuntimeError):
    """A core raised, died or hung; `results` are those of the calls before it."""

    def __init__(self, message: str, results: list[list[Any]]) -> None:
        super().__init__(message)
        self.results = results


def core_health(core: Estimator) -> dict[str, Any]:
    """The core's health (`Estimator.health`); a report that fails says why instead."""
    try:
        return core.health()
    except Exception as exc:  # a core's report must not take its worker down
        return {"health_error": f"{type(exc).__name__}: {exc}"}


def run_calls(core: Estimator, calls: list[Call], results: list[list[Any]]) -> None:
    """Run `calls` in order, appending each one's estimates to `results` (so that a
    call that raises leaves the results of the ones before it)."""
    step, tick = core.step, core.tick
    for what, arg in calls:
        results.append(list(step(arg) if what == "step" else tick(arg)))


class LoopRunner:
    """Calls the core in the event loop, one batch at a time."""

    placement = "loop"
    max_calls = MAX_CALLS
    depth = 1

    def __init__(self, plugin: EstimatorPlugin) -> None:
        self.plugin = plugin
        self.core: Estimator | None = plugin.make_core()
        self.health_report: dict[str, Any] | None = None

    async def start(self) -> None:
        if self.core is None:
            self.core = self.plugin.make_core()

    async def call(self, calls: list[Call]) -> list[list[Any]]:
        results: list[list[Any]] = []
        try:
            assert self.core is not None, "called before start()"
            with core_step():
                run_calls(self.core, calls, results)
        except Exception as exc:
            raise CoreFailed(f"{type(exc).__name__}: {exc}", results) from exc
        except StopRequested as exc:  # a stop signal, and the step would not end
            raise CoreFailed(f"stopped: {exc}", results) from None
        return results

    def report(self) -> dict[str, Any] | None:
        return core_health(self.core) if self.core is not None else self.health_report

    def info(self) -> dict[str, Any]:
        return {}

    async def stop(self) -> None:
        """Forget the core: the next start() makes a fresh one. Its last health is kept,
        so the final snapshot (after a replay) describes the whole run."""
        if self.core is not None:
            self.health_report = core_health(self.core)
        self.core = None

    def kill_now(self) -> None:
        """(nothing runs elsewhere)"""

    def close(self) -> None:
        """(nothing to release)"""


class _CoreServant:
    """(in the child) The core, made there; a batch of calls per message."""

    def __init__(self, core: Estimator) -> None:
        self.core = core

    def call(self, what: str, arg: Any) -> list[list[Any]]:
        if what != "calls":
            raise ValueError(f"unknown call {what!r}")
        results: list[list[Any]] = []
        try:
            run_calls(self.core, arg, results)
        except Exception as exc:
            raise CallFailed(f"{type(exc).__name__}: {exc}", results) from None
        return results

    def report(self) -> dict[str, Any] | None:
        return core_health(self.core)


def make_core_servant(clock: Any, plugin_cls: type[EstimatorPlugin], config: Any, name: str,
                      vessel_id: str, config_dir: str) -> _CoreServant:
    """(in the child) The plugin made again there, and its core; paths in its
    configuration are relative to the configuration file's folder, as in the parent."""
    health = ComponentHealth(name, "estimator", config.type, clock)
    ctx = PluginContext(name=name, clock=clock, health=health, publish=lambda rec: None, vessel_id=vessel_id,
                        config_dir=Path(config_dir))
    return _CoreServant(plugin_cls(config, ctx).make_core())


class ProcessRunner:
    """Runs the core in a process of its own: a batch goes as messages of
    CHUNK_PROCESS calls, all sent at once (the child always has the next to hand), and
    the loop only awaits their answers. The core's health comes with each answer."""

    placement = "process"
    max_calls = MAX_CALLS_PROCESS
    depth = 2

    def __init__(self, plugin: EstimatorPlugin, name: str, watchdog: float) -> None:
        self.plugin = plugin
        self.name = name
        self.health_report: dict[str, Any] | None = None
        self.child = ChildProcess(name, make_core_servant, plugin.ctx.clock, watchdog, self._reported)

    def _reported(self, report: dict[str, Any] | None) -> None:
        self.health_report = report

    @property
    def pid(self) -> int | None:
        return self.child.pid

    @property
    def process(self) -> Any:
        return self.child.process

    async def start(self) -> None:
        if self.child.alive:
            return
        args = (type(self.plugin), self.plugin.config, self.name, self.plugin.ctx.vessel_id,
                str(self.plugin.ctx.config_dir))
        try:
            await self.child.start(args, "worker")
        except RuntimeError as exc:
            raise CoreFailed(f"core did not start: {exc}", []) from None

    async def call(self, calls: list[Call]) -> list[list[Any]]:
        chunks = [self.child.submit("calls", calls[i : i + CHUNK_PROCESS])
                  for i in range(0, len(calls), CHUNK_PROCESS)]
        results: list[list[Any]] = []
        try:
            for fut in chunks:
                results.extend(await fut)
        except CallFailed as exc:
            raise CoreFailed(exc.message, results + exc.value) from None
        except ChildDied as exc:
            raise CoreFailed(str(exc), results) from None
        finally:
            # (after a failure the rest are answered by the core that failed, or fail
            # with its process: nobody applies them)
            for fut in chunks:
                forget(fut)
        return results

    def report(self) -> dict[str, Any] | None:
        return self.health_report

    def info(self) -> dict[str, Any]:
        return {"pid": self.pid}

    async def stop(self) -> None:
        await self.child.stop()

    def kill_now(self) -> None:
        """From the event loop, when a batch did not come back in time at shutdown:
        the child goes at once (the batch's wait then ends)."""
        self.child.kill_now()

    def close(self) -> None:
        """Last words at shutdown: the child and the writer thread go."""
        self.child.close()
