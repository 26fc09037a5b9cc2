"""Benchmark: measurements per second through the router to a no-op worker.

Run: .venv/bin/python tests/bench/bench_router.py [N]
Target (issue 2): at least 200,000 measurements/s on one core, so that the router is
never the bottleneck. Prints three figures: publish into one queue, the same with a
worker task draining it (the real path), and fan-out to four subscribers with a
source priority on the kind.
"""

from __future__ import annotations

import asyncio
import sys
import time

from edged.clock import ManualClock
from edged.estimator import Estimator, handles
from edged.health import ComponentHealth
from edged.plugin import EstimatorConfig, EstimatorPlugin
from edged.records import KINDS, Measurement
from edged.router import Router
from edged.workers import WorkerHost


def _measurements(n: int) -> list[Measurement]:
    kinds = ["draft"] * 6 + ["accel_body", "yaw_rate", "position", "heading"]
    return [Measurement(kinds[i % len(kinds)], "src", i * 0.001, {"x": 1.0}) for i in range(n)]


class _NoopCore(Estimator):
    """Takes every measurement kind and makes nothing; sets `done` at the n-th."""

    def __init__(self, config: EstimatorConfig, n: int, done: asyncio.Event) -> None:
        super().__init__(config)
        self.left = n
        self.done = done

    @handles(*KINDS)
    def _any(self, rec: Measurement) -> None:
        self.left -= 1
        if not self.left:
            self.done.set()


async def _through_worker(ms: list[Measurement]) -> float:
    """The real path: router -> bounded queue -> WorkerHost task -> core.step."""
    r = Router()
    done = asyncio.Event()
    n = len(ms)
    clock = ManualClock()

    class Noop(EstimatorPlugin):
        Core = _NoopCore

        def make_core(self) -> _NoopCore:  # (not from the configuration alone)
            return _NoopCore(self.config, n, done)

    # No stale ticks: the figure is the host's cost per measurement, nothing else.
    plugin = Noop(EstimatorConfig(type="noop", queue_size=min(n + 1, 10_000_000), stale_after=0.0), None)  # type: ignore[arg-type]
    host = WorkerHost("noop", plugin, r, ComponentHealth("noop", "estimator", "noop", clock))
    task = asyncio.ensure_future(host.run())
    t0 = time.perf_counter()
    publish = r.publish
    for i, m in enumerate(ms):
        publish(m)
        if i % 4096 == 4095:
            await asyncio.sleep(0)
    await done.wait()
    dt = time.perf_counter() - t0
    task.cancel()
    return n / dt


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    ms = _measurements(n)

    r = Router()
    sub = r.subscribe("noop", None, maxsize=n + 1)
    t0 = time.perf_counter()
    for m in ms:
        r.publish(m)
    rate_publish = n / (time.perf_counter() - t0)
    assert len(sub.queue) == n

    rate_worker = asyncio.run(_through_worker(ms))

    r = Router()
    r.set_priority("heading", ["src", "other"], 2.0)
    subs = [r.subscribe(f"s{i}", None, maxsize=n + 1, preferred_only=bool(i % 2)) for i in range(4)]
    t0 = time.perf_counter()
    for m in ms:
        r.publish(m)
    rate_fan = n / (time.perf_counter() - t0)
    assert all(len(s.queue) == n for s in subs)

    print(f"router publish, 1 queue:          {rate_publish:>12,.0f} measurements/s")
    print(f"router -> WorkerHost -> no-op core:{rate_worker:>12,.0f} measurements/s")
    print(f"router fan-out to 4 + priority:   {rate_fan:>12,.0f} measurements/s")
    print("target: >= 200,000 measurements/s through the router to a no-op worker")


if __name__ == "__main__":
    main()
