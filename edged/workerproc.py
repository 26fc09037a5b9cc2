"""The estimator core's side of a process worker (`worker = "process"`).

The parent (`edged.workers.ProcessRunner`) starts this in a fresh interpreter (the
multiprocessing "spawn" method: no copy of the daemon's threads, sockets or zenoh
session), sends batches of calls and receives, per call, what the core returned.
The core is made here, from the plugin's class and configuration, so it need not be
picklable itself; records and estimates are.

Messages (parent -> child): `("calls", [("step", record) | ("tick", t), ...])`,
`("stop",)`. Child -> parent: `("ready",)` once the core exists, then per batch
`("ok", results, health)` or `("error", results_so_far, message, health)`.
"""

from __future__ import annotations

from multiprocessing.connection import Connection
from typing import Any

from .clock import ReplayClock
from .health import ComponentHealth
from .signals import ignore_stop_signals
from .plugin import EstimatorPlugin, PluginContext

__all__ = ["serve", "run_calls", "core_health"]

Call = tuple[str, Any]


def core_health(core: Any) -> dict[str, Any] | None:
    """The core's own health (`health()`), or None when it has none or it fails."""
    fn = getattr(core, "health", None)
    if not callable(fn):
        return None
    try:
        h = fn()
    except Exception as exc:  # a core's report must not take its worker down
        return {"health_error": f"{type(exc).__name__}: {exc}"}
    return h if isinstance(h, dict) else None


def run_calls(core: Any, calls: list[Call], results: list[list[Any]]) -> None:
    """Run `calls` in order, appending each one's estimates to `results` (so that a
    call that raises leaves the results of the ones before it)."""
    step = core.step
    tick = getattr(core, "tick", None)
    for what, arg in calls:
        if what == "step":
            results.append(list(step(arg)))
        elif tick is not None:
            results.append(list(tick(arg)))
        else:
            results.append([])


def serve(conn: Connection, plugin_cls: type[EstimatorPlugin], config: Any, name: str, vessel_id: str) -> None:
    """The child's main loop; returns when told to stop or when the parent is gone."""
    ignore_stop_signals()
    clock = ReplayClock()
    health = ComponentHealth(name, "estimator", getattr(config, "type", ""), clock)
    ctx = PluginContext(name=name, clock=clock, health=health, publish=lambda rec: None, vessel_id=vessel_id)
    try:
        core = plugin_cls(config, ctx).make_core()
    except Exception as exc:
        conn.send(("error", [], f"make_core: {type(exc).__name__}: {exc}", None))
        return
    conn.send(("ready",))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):  # the parent died or closed the pipe
            return
        if msg[0] != "calls":
            return
        results: list[list[Any]] = []
        try:
            run_calls(core, msg[1], results)
        except Exception as exc:
            conn.send(("error", results, f"{type(exc).__name__}: {exc}", core_health(core)))
            continue
        conn.send(("ok", results, core_health(core)))
