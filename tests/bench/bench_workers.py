"""Benchmark: the estimator worker host (`edged.workers`) in the event loop and in a process.

Run: .venv/bin/python tests/bench/bench_workers.py [--seconds 120] [--runs 5] [--live 12]
(about a minute; exit status 1 when the process worker's longest stall misses 5 ms)

Fed the reference load of DESIGN §9 (seeded, synthetic, valid for `edged.records`):
six draft marks at 100 Hz, IMU accelerations and rates at 50 Hz each, GNSS position and
SOG/COG at 10 Hz, heading and rate of turn at 10 Hz, the Doppler log at 1 Hz
(741 measurements per second of data).

1. Throughput: a Runtime with one estimator (a core of this file that consumes those
   seven kinds and returns one `stw`-shaped estimate per step), fed as fast as
   possible the way the replay driver feeds it (a yield every 512 records, a wait
   while the worker's queue is more than half full, a health snapshot per second of
   data). Printed per placement: µs per measurement (wall, and CPU of the parent
   process: event loop plus its threads; for `process` also the child's CPU),
   measurements/s and the real-time factor (seconds of data per wall second,
   = rate / 741), min and median of several runs. A first row feeds the same stream
   to a Runtime without estimators: the feed's and the router's own cost.
2. Loop stalls: the same stream paced in wall time (a live Runtime, LiveClock, its
   1 Hz health timer running) to a deliberately slow core (`step_delay` per step),
   while a ticker in the same loop sleeps 1 ms at a time and records how late each
   wake-up is. Target: the longest stall under 5 ms with `worker = "process"`. First
   the same feed without an estimator (the ticker's and the machine's own floor: on a
   shared or loaded machine it is already above 5 ms), then a core that cannot keep up
   (step_delay 2 ms: 148 % of its time, its queue grows, batches reach MAX_CALLS), a
   core that keeps up (1 ms: 74 %), and the loop placement with the slow core for
   contrast (it stalls for whole batches of steps: what the process placement is for).
   Each stall over 5 ms is matched against what overlapped it (the host's `prepare`
   and `apply` in the loop, the pickling of the calls sent (`send`, in the loop), the
   garbage collector, the health snapshot), and one full batch's parts are timed alone.

Nothing is bound to the network; the only child processes are the process workers.
Not a pytest test (no `test_` prefix): run it on demand.
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import math
import os
import random
import statistics
import sys
import time
from typing import Any

from procstat import cpu_seconds  # noqa: E402  (this folder)

from edged.clock import LiveClock, ReplayClock
from edged.config import parse_config
from edged.datatime import CallPlan
from edged.estimator import Estimator, handles
from edged.plugin import EstimatorConfig, EstimatorPlugin
from edged.records import Estimate, Measurement, validate_measurement
from edged.registry import Registry
from edged.runtime import Runtime
from edged.workerproc import MAX_CALLS, MAX_CALLS_PROCESS, ProcessRunner

REFERENCE_RATE = 741.0  # measurements per second of data (DESIGN §9: "about 740")
STALL_TARGET = 0.005  # s
TICK = 0.001  # s
SEED = 20240917
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")
KINDS_FED = ("draft", "accel_body", "yaw_rate", "position", "velocity_ground", "heading", "water_speed")


# -- the estimator under test ---------------------------------------------------------
class BenchConfig(EstimatorConfig):
    #: Seconds each step sleeps (a deliberately slow filter).
    step_delay: float = 0.0


class BenchCore(Estimator):
    """Consumes the reference-load kinds; one `stw`-shaped estimate per step."""

    def __init__(self, cfg: BenchConfig) -> None:
        super().__init__(cfg)
        self.delay = cfg.step_delay
        self.n = 0
        self.x = 0.0

    @handles(*KINDS_FED)
    def _any(self, rec: Measurement) -> list[Estimate]:
        if self.delay:
            time.sleep(self.delay)
        self.n += 1
        self.x = 0.99 * self.x + 0.01 * (self.n % 7)
        x = self.x
        return [
            Estimate(
                "bench",
                "bench",
                rec.t,
                {
                    "stw": 5.0 + x,
                    "stw_std": 0.05,
                    "sog": 5.1 + x,
                    "current": 0.2,
                    "distance": 2.5 * self.n,
                    "mode": "vector",
                    "stw_long": 5.0 + x,
                    "stw_trans": 0.01 * x,
                    "n": self.n,
                },
            )
        ]


class BenchEstimator(EstimatorPlugin):
    Config = BenchConfig
    Core = BenchCore
    kind = "stw"


def _registry() -> Registry:
    r = Registry(use_entry_points=False)
    r.register("estimators", "bench", BenchEstimator)
    return r


def _runtime(placement: str | None, clock: Any, *, replay: bool, step_delay: float = 0.0) -> Runtime:
    est = {}
    if placement is not None:
        est = {"bench": {"type": "bench", "worker": placement, "step_delay": step_delay}}
    reg = _registry()
    return Runtime(parse_config({"estimators": est}, reg), reg, clock, replay=replay)


# -- the reference load ---------------------------------------------------------------
def reference_schedule(seconds: float, seed: int = SEED) -> list[tuple[float, str, str, dict[str, Any]]]:
    """(offset in s, kind, source, values) for `seconds` of the reference load, in time
    order. Each stream has a random phase within its period; values wander (seeded)."""
    rng = random.Random(seed)
    streams: list[tuple[str, str, float, Any]] = []
    for mark in MARKS:
        base = rng.uniform(4.0, 9.0)
        streams.append(("draft", "can0.DraftMark", 100.0,
                        lambda k, m=mark, b=base: {"mark": m, "draft": b + 0.02 * rng.gauss(0, 1), "status": 0}))
    streams += [
        ("accel_body", "imu", 50.0,
         lambda k: {"ax": rng.gauss(0, 0.05), "ay": rng.gauss(0, 0.3), "az": rng.gauss(0, 0.5)}),
        ("yaw_rate", "imu", 50.0, lambda k: {"r": rng.gauss(0, 0.01)}),
        ("position", "gnss", 10.0,
         lambda k: {"lat": 53.5 + 1e-6 * k, "lon": 8.1 + 2e-6 * k, "fix_quality": 1, "hdop": 0.9, "sats": 11}),
        ("velocity_ground", "gnss", 10.0,
         lambda k: {"sog": abs(5.0 + rng.gauss(0, 0.05)), "cog": (1.0 + rng.gauss(0, 0.01)) % (2 * math.pi)}),
        ("heading", "gyro", 10.0, lambda k: {"heading": (1.02 + rng.gauss(0, 0.005)) % (2 * math.pi)}),
        ("yaw_rate", "gyro", 10.0, lambda k: {"r": rng.gauss(0, 0.01)}),
        ("water_speed", "log", 1.0, lambda k: {"stw_long": 4.9 + rng.gauss(0, 0.05), "stw_trans": rng.gauss(0, 0.02)}),
    ]
    out = []
    for kind, source, hz, values in streams:
        period = 1.0 / hz
        phase = rng.uniform(0.0, period)
        for k in range(int(round(seconds * hz))):
            v = values(k)
            validate_measurement(kind, v)
            out.append((phase + k * period, kind, source, v))
    out.sort(key=lambda e: e[0])
    return out


# -- helpers --------------------------------------------------------------------------


async def _until(cond, timeout: float = 60.0, poll: float = 0.0005) -> None:
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout
    while not cond():
        if loop.time() > end:
            raise RuntimeError("benchmark: condition not reached (a worker failed?)")
        await asyncio.sleep(poll)


async def _started(rt: Runtime) -> None:
    await _until(lambda: all(w.health.state == "running" for w in rt.workers))


def _pct(sorted_xs: list[float], q: float) -> float:
    if not sorted_xs:
        return float("nan")
    return sorted_xs[min(len(sorted_xs) - 1, int(q * len(sorted_xs)))]


# -- 1. throughput --------------------------------------------------------------------
async def throughput_run(placement: str | None, sched: list, data_seconds: float) -> dict[str, float]:
    t_base = 1_700_000_000.0
    ms = [Measurement(kind, src, t_base + off, v) for off, kind, src, v in sched]
    clock = ReplayClock(t_base)
    rt = _runtime(placement, clock, replay=True)
    await rt.start()
    await _started(rt)
    w = rt.workers[0] if rt.workers else None
    pid = w.runner.pid if w is not None and isinstance(w.runner, ProcessRunner) else None
    publish = rt.router.publish
    wlimit = min((x.sub.queue.maxsize // 2 for x in rt.workers), default=0)
    gc.collect()
    child0 = cpu_seconds(pid)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    next_tick = t_base + 1.0
    for i, m in enumerate(ms):
        clock.advance_to(m.t)
        publish(m)
        if m.t >= next_tick:  # health in data time, as the replay driver does
            rt.tick(flush=False)
            next_tick += 1.0
        if i % 512 == 511:
            await asyncio.sleep(0)
            spins = 0
            while rt.workers and rt.worker_backlog() > wlimit:
                spins += 1
                await asyncio.sleep(0 if spins < 64 else 0.0005)
    n = len(ms)
    # Done when every measurement is stepped. Not `watermark() >= router.seq` (the tests'
    # settle()): with more than 1024 records queued, the watermark runs ahead of them.
    await _until(lambda: w is None or (w.health.counters.get("steps", 0) >= n and not w.order.busy))
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    child1 = cpu_seconds(pid)
    res = {"wall_us": wall / n * 1e6, "cpu_us": cpu / n * 1e6, "rate": n / wall, "rtf": data_seconds / wall}
    if child0 is not None and child1 is not None:
        res["child_us"] = (child1 - child0) / n * 1e6
    if w is not None:
        steps = w.health.counters.get("steps", 0)
        lost = w.sub.overflow + sum(v for k, v in w.health.counters.items() if k.startswith("dropped") or k == "late")
        if steps != n or lost:
            raise RuntimeError(f"benchmark: {placement} stepped {steps} of {n} measurements, {lost} lost")
        if w.health.restarts:
            raise RuntimeError(f"benchmark: the {placement} worker restarted: {w.health.last_error}")
    await rt.stop()
    return res


def _throughput(label: str, runs: list[dict[str, float]]) -> str:
    def mm(key: str, fmt: str) -> str:
        xs = [r[key] for r in runs]
        best = max(xs) if key in ("rate", "rtf") else min(xs)
        return f"{format(best, fmt)} / {format(statistics.median(xs), fmt)}"

    line = (
        f"{label:<26} wall {mm('wall_us', '6.2f')} µs   cpu {mm('cpu_us', '6.2f')} µs   "
        f"{mm('rate', '9,.0f')} meas/s   RTF {mm('rtf', '6.0f')}"
    )
    if all("child_us" in r for r in runs):
        line += f"   child cpu {mm('child_us', '5.2f')} µs"
    return line


# -- 2. loop stalls -------------------------------------------------------------------
class _Events:
    """Intervals (perf_counter) of what may hold the loop or the GIL, for attributing
    stalls: diagnosis only, wrapped around the host's methods without changing them."""

    def __init__(self) -> None:
        self.spans: list[tuple[float, float, str, int]] = []
        self._gc0 = 0.0
        self.until = math.inf  # the end of the measured window

    def add(self, t0: float, what: str, n: int = 0) -> None:
        self.spans.append((t0, time.perf_counter(), what, n))

    def on_gc(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._gc0 = time.perf_counter()
        else:
            self.add(self._gc0, f"gc{info.get('generation', '')}")

    def instrument(self, rt: Runtime) -> None:
        ev = self
        tick = rt.tick

        def _tick(flush: bool = True) -> None:
            t0 = time.perf_counter()
            tick(flush)
            ev.add(t0, "health")

        rt.tick = _tick  # type: ignore[method-assign]
        for w in rt.workers:
            work, apply, call, entered = w._work, w.out.apply, w.runner.call, [None]
            in_loop = not isinstance(w.runner, ProcessRunner)

            async def _work(items: list, final: bool = False, _work=work, _e=entered) -> None:
                _e[0] = time.perf_counter()
                await _work(items, final)

            async def _call(calls: list, _call=call, _e=entered, _in_loop=in_loop) -> list:
                if _e[0] is not None:  # the first batch began before the wrapping
                    ev.add(_e[0], "prepare", len(calls))  # order.take + plan.admit of this batch
                t0 = time.perf_counter()
                out = await _call(calls)
                if _in_loop:
                    ev.add(t0, "core", len(calls))  # the core's steps, in the loop
                return out

            def _apply(calls: list, results: list, causes: list, _apply=apply) -> None:
                t0 = time.perf_counter()
                _apply(calls, results, causes)
                ev.add(t0, "apply", len(calls))

            w._work, w.out.apply, w.runner.call = _work, _apply, _call  # type: ignore[method-assign]

    def instrument_pipe(self, runner: ProcessRunner) -> None:
        """The pickling of each message to the child: `send` = `ChildProcess.submit`,
        in the loop (dumps, then its bytes handed to the writer thread). There is no
        "recv" figure any more: the answers are read and unpickled by the receiver
        thread inside `edged.childproc`, which has no method to wrap from here (a
        long unpickling shows as a stall that nothing recorded overlapped)."""
        child, ev = runner.child, self
        submit = child.submit

        def _submit(what: str, arg: Any = None, **kw: Any) -> Any:
            t0 = time.perf_counter()
            fut = submit(what, arg, **kw)
            ev.add(t0, "send", len(arg) if what == "calls" else 0)
            return fut

        child.submit = _submit  # type: ignore[method-assign]

    def blame(self, stalls: list[tuple[float, float]]) -> dict[str, int]:
        """For each stall (the interval the loop did not answer), what overlapped it."""
        out: dict[str, int] = {}
        for a, b in stalls:
            kinds = sorted({what for s, e, what, _ in self.spans if e > a and s < b})
            key = "+".join(kinds) if kinds else "nothing recorded (the machine?)"
            out[key] = out.get(key, 0) + 1
        return out

    def longest(self, what: str) -> tuple[float, int]:
        xs = [(e - s, n) for s, e, k, n in self.spans if k == what and s < self.until]
        return max(xs, default=(0.0, 0))


async def stall_run(placement: str | None, step_delay: float, sched: list, seconds: float) -> dict[str, Any]:
    clock = LiveClock()
    rt = _runtime(placement, clock, replay=False, step_delay=step_delay)
    await rt.start()
    await _started(rt)
    w = rt.workers[0] if rt.workers else None
    ev = _Events()
    ev.instrument(rt)
    if w is not None and isinstance(w.runner, ProcessRunner):
        ev.instrument_pipe(w.runner)
    loop = asyncio.get_running_loop()
    gaps: list[float] = []
    stalls: list[tuple[float, float]] = []
    running = True

    async def ticker() -> None:
        sleep, now, pc = asyncio.sleep, loop.time, time.perf_counter
        while running:
            expected = now() + TICK
            p0 = pc()
            await sleep(TICK)
            g = now() - expected
            gaps.append(g)
            if g > STALL_TARGET:
                stalls.append((p0 + TICK, pc()))

    gc.collect()
    gc.callbacks.append(ev.on_gc)
    tick_task = loop.create_task(ticker())
    await asyncio.sleep(0.05)  # the ticker's first wake-ups before the feed
    publish = rt.router.publish
    late_max = 0.0
    t0 = clock.now()
    start = loop.time()
    for off, kind, src, v in sched:
        if off >= seconds:
            break
        delay = start + off - loop.time()
        if delay > 0:
            await asyncio.sleep(delay)
        elif -delay > late_max:
            late_max = -delay
        publish(Measurement(kind, src, t0 + off, v))
    running = False
    await tick_task
    ev.until = time.perf_counter()
    gc.callbacks.remove(ev.on_gc)
    fed = sum(1 for e in sched if e[0] < seconds)
    res: dict[str, Any] = {"fed": fed, "gaps": sorted(gaps), "late_max": late_max, "ev": ev,
                           "blame": ev.blame(stalls)}
    if w is not None:
        c = w.health.counters
        res.update(
            steps=c.get("steps", 0),
            backlog=len(w.sub.queue) + len(w.order.pending),
            overflow=w.sub.overflow,
            dropped=sum(v for k, v in c.items() if k.startswith("dropped")),
            late=c.get("late", 0),
            restarts=w.health.restarts,
            batches=[n for _, _, k, n in ev.spans if k == "prepare"],
        )
        # The backlog of a saturated core is not worth stepping: stop it here.
        if w.task is not None:
            w.task.cancel()
            await asyncio.wait([w.task], timeout=30.0)
    await rt.stop()
    return res


def _stall(label: str, r: dict[str, Any]) -> list[str]:
    g, ev = r["gaps"], r["ev"]
    gcs = [(e - s) for s, e, k, _ in ev.spans if k.startswith("gc")]
    out = [
        f"{label}",
        f"    wake-up lateness over {len(g)} ticks: max {max(g) * 1e3:8.2f} ms   p99 {_pct(g, 0.99) * 1e3:6.2f} ms"
        f"   p50 {_pct(g, 0.50) * 1e3:5.2f} ms   (> 5 ms: {sum(1 for x in g if x > STALL_TARGET)})",
        f"    feed: {r['fed']} measurements, latest publication {r['late_max'] * 1e3:.1f} ms behind schedule;"
        f"   gc: {len(gcs)} collections, longest {max(gcs, default=0.0) * 1e3:.2f} ms",
    ]
    if "steps" in r:
        b = r["batches"]
        out.append(
            f"    worker: {r['steps']} stepped, backlog {r['backlog']} at the end, overflow {r['overflow']},"
            f" dropped {r['dropped']}, late {r['late']}, restarts {r['restarts']};"
            f" batches {len(b)}, calls per batch p50 {_pct(sorted(b), 0.5):.0f} max {max(b, default=0)}"
            f" (at most {MAX_CALLS} in the loop, {MAX_CALLS_PROCESS} to a process)"
        )
        parts = []
        for what, where in (("core", "loop"), ("prepare", "loop"), ("apply", "loop"), ("send", "loop")):
            d, n = ev.longest(what)
            if n or d:
                parts.append(f"{what} ({where}) {d * 1e3:.2f} ms for {n} calls")
        out.append("    longest host segments: " + ", ".join(parts))
    if r["blame"]:
        out.append("    stalls > 5 ms overlapped: " + ", ".join(f"{k} x{v}" for k, v in sorted(r["blame"].items())))
    return out


def full_batch_costs(sched: list) -> tuple[dict[str, float], str]:
    """What one full batch (MAX_CALLS step calls) costs, each part timed alone (min of 9,
    so the machine's noise mostly drops out): pickle's dumps of the calls (in the loop,
    `ChildProcess.submit`) and loads of the results (in the receiver thread; C code: the
    GIL is held throughout); in the loop, `prepare` (`order.take` + `plan.admit`) and
    `out.apply` (stamp + publish) of the host."""
    from multiprocessing.reduction import ForkingPickler

    ms = [Measurement(kind, src, 1_700_000_000.0 + off, v) for off, kind, src, v in sched[:MAX_CALLS]]
    core = BenchCore(BenchConfig(type="bench"))
    calls = [("step", m) for m in ms]
    results = [core.step(m) for m in ms]
    out_msg = ("calls", calls)
    in_bytes = bytes(ForkingPickler.dumps(("ok", results, None)))
    out_bytes = bytes(ForkingPickler.dumps(out_msg))
    rt = _runtime("loop", ReplayClock(ms[0].t), replay=True)
    w = rt.workers[0]
    causes = list(range(1, len(ms) + 1))
    items = list(zip(causes, ms))

    cfg = w.plugin.config
    ticking = cfg.publish_rate > 0 or cfg.stale_after > 0 or w.plugin.ticks()

    def prepare() -> None:
        w.order.pending.clear()
        w.plan = CallPlan(w.health, cfg.reorder_window, cfg.publish_rate, ticking)  # no time seen yet
        w.order.take(items)
        c: list = []
        cs: list = []
        pending = w.order.pending
        while pending:
            seq, _, _, rec = pending.popleft()
            w.plan.admit(seq, rec, c, cs)

    def apply() -> None:
        w.out.apply(calls, results, causes)
        w.sub.queue.drain_nowait()  # its own estimates are not its input; keep it empty

    def best(f: Any) -> float:
        ts = []
        for _ in range(9):
            t0 = time.perf_counter()
            f()
            ts.append(time.perf_counter() - t0)
        return min(ts)

    cost = {
        "dumps": best(lambda: ForkingPickler.dumps(out_msg)),
        "loads": best(lambda: ForkingPickler.loads(in_bytes)),
        "prepare": best(prepare),
        "apply": best(apply),
    }
    c = {k: v * 1e3 for k, v in cost.items()}
    line = (
        f"    one full batch of {MAX_CALLS} calls, each part alone (min of 9), GIL held: dumps (loop)"
        f" {c['dumps']:.2f} ms ({len(out_bytes) // 1024} KiB), loads of the results (receiver thread)"
        f" {c['loads']:.2f} ms ({len(in_bytes) // 1024} KiB); loop: apply {c['apply']:.2f} ms,"
        f" prepare {c['prepare']:.2f} ms\n"
        f"    back to back when a full batch returns to a saturated worker (loads, apply, the next batch's"
        f" prepare, its dumps): {sum(c.values()):.2f} ms without the loop"
    )
    return cost, line


# -- main -----------------------------------------------------------------------------
async def amain(args: argparse.Namespace) -> int:
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, pid {os.getpid()}, seed {SEED}")
    sched = reference_schedule(args.seconds)
    kinds: dict[str, int] = {}
    for _, kind, _, _ in sched:
        kinds[kind] = kinds.get(kind, 0) + 1
    print(
        f"reference load: {len(sched) / args.seconds:.0f} measurements per s of data "
        f"({', '.join(f'{k} {v / args.seconds:g}/s' for k, v in kinds.items())})"
    )
    print()
    print(f"1. worker host throughput: {args.seconds:g} s of data ({len(sched)} measurements) as fast as possible,"
          f" {args.runs} runs, best / median; per measurement")
    rows = [("router only (no estimator)", None), ('worker = "loop"', "loop"), ('worker = "process"', "process")]
    results: dict[str | None, list[dict[str, float]]] = {}
    for label, placement in rows:
        runs = [await throughput_run(placement, sched, args.seconds) for _ in range(args.runs)]
        results[placement] = runs
        print(_throughput(label, runs), flush=True)
    base = statistics.median(r["cpu_us"] for r in results[None])
    for placement in ("loop", "process"):
        host = statistics.median(r["cpu_us"] for r in results[placement]) - base
        print(f"  worker host alone ({placement}): {host:.2f} µs CPU per measurement in the parent (median minus router only)")
    print()
    live = reference_schedule(max(args.live, args.baseline, args.loop_live), seed=SEED + 1)
    d, d2 = args.step_delay, args.keepup_delay
    print(
        f"2. event loop stalls: the reference load paced in wall time, a ticker sleeping {TICK * 1e3:g} ms"
        f" in the same loop; target: longest stall < {STALL_TARGET * 1e3:g} ms with worker = \"process\""
    )
    print("\n".join(_stall(f"no estimator, {args.baseline:g} s (the ticker's and the machine's own floor)",
                           await stall_run(None, d, live, args.baseline))), flush=True)
    proc = await stall_run("process", d, live, args.live)
    lines = _stall(f'worker = "process", step_delay {d * 1e3:g} ms ({d * REFERENCE_RATE:.0%} of the core\'s time'
                   f" at 741/s: always busy, its queue grows), {args.live:g} s", proc)
    lines.append(full_batch_costs(live)[1])
    verdict = "PASS" if max(proc["gaps"]) < STALL_TARGET else "FAIL"
    lines.append(f"    longest stall {max(proc['gaps']) * 1e3:.2f} ms, target < {STALL_TARGET * 1e3:g} ms: {verdict}")
    print("\n".join(lines), flush=True)
    if d2 > 0:
        keep = await stall_run("process", d2, live, args.live)
        lines = _stall(f'worker = "process", step_delay {d2 * 1e3:g} ms ({d2 * REFERENCE_RATE:.0%}: busy, keeping up),'
                       f" {args.live:g} s", keep)
        v2 = "PASS" if max(keep["gaps"]) < STALL_TARGET else "FAIL"
        lines.append(f"    longest stall {max(keep['gaps']) * 1e3:.2f} ms, target < {STALL_TARGET * 1e3:g} ms: {v2}")
        print("\n".join(lines), flush=True)
    loop_r = await stall_run("loop", d, live, args.loop_live)
    print("\n".join(_stall(f'worker = "loop", step_delay {d * 1e3:g} ms (contrast), {args.loop_live:g} s', loop_r)),
          flush=True)
    return 0 if verdict == "PASS" else 1


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seconds", type=float, default=120.0, help="seconds of data per throughput run (default 120)")
    p.add_argument("--runs", type=int, default=5, help="throughput runs per placement (default 5)")
    p.add_argument("--live", type=float, default=12.0, help="wall seconds of the paced feed, process worker (default 12)")
    p.add_argument("--baseline", type=float, default=4.0, help="wall seconds of the paced feed without estimator")
    p.add_argument("--loop-live", type=float, default=6.0, help="wall seconds of the paced feed, loop worker")
    p.add_argument("--step-delay", type=float, default=0.002,
                   help="seconds each step of the slow core sleeps (default 0.002: more than the load allows)")
    p.add_argument("--keepup-delay", type=float, default=0.001,
                   help="a second process run with this step_delay, a core that keeps up (0: skip)")
    sys.exit(asyncio.run(amain(p.parse_args())))


if __name__ == "__main__":
    main()
