"""Benchmark: the STW estimator core (`edged_stw.core.StwCore`), steps per second and a 24 h suite.

Run: .venv/bin/python tests/bench/bench_stw.py [--seconds 300] [--runs 3] [--hours 24]
(the 24 h part takes about as long as the CPU time it prints; `--hours 0` skips it)

The stream is the reference sensor suite of DESIGN §9 without the draft marks (the STW
estimator does not consume them), built in code as `edged.records.Measurement`s for a
vessel steaming at 10 m/s through the water on a steady course (060°) in a steady
current (0.5 m/s toward 150°), seeded noise on every sensor:

    position, velocity_ground (GNSS)   10 Hz each   σ 2.5 m, σ 0.065 m/s on the vector
    heading, yaw_rate (gyro)           10 Hz each   σ 0.5°, σ 0.001 rad/s
    accel_body, yaw_rate (IMU)         50 Hz each   σ 0.05 m/s² (ax, ay, az), σ 0.001 rad/s
    water_speed (Doppler log)           1 Hz        stw_long 0.3 m/s high, σ 0.1 m/s
    current (forecast)                 every 20 min σ 0.2 m/s per component, t_src = t

(141 measurements per second of data). Each stream has a seeded phase within its
period; GNSS positions are integrated on the WGS-84 ellipsoid from the true ground
velocity, so positions and SOG/COG agree. The stream is generated lazily, in blocks of
`--block` seconds of data: only the block being fed is in memory (the peak RSS is
printed), and the generation is outside every timed interval.

1. Filter steps per second (`StwCore.step`: predict to the measurement + its update),
   best / median of `--runs` passes over `--seconds` of data, for each mix of inputs a
   vessel may have (the reference suite; without the IMU; GNSS + gyro only; GNSS only),
   the reference suite in `mode = "paper"`, and the reference suite with publish ticks
   at 1 Hz (`core.tick`, fired before each record as the worker host does: every tick
   <= its time). Then the cost of one step per measurement kind inside the reference
   mix (per-call perf_counter, so a little above the loop's figure) and of one tick.
2. `--hours` (default 24) of the reference suite fed through one core with ticks at
   1 Hz: CPU seconds (time.process_time, step + tick only) and the real-time factor
   (hours of data / CPU seconds; DESIGN §9's RTF is per wall second on one core: the
   wall time is printed too). The last estimate is set beside the truth, and every
   published estimate is checked for NaN/inf.

Not a pytest test (no `test_` prefix): run it on demand.
"""

from __future__ import annotations

import argparse
import gc
import hashlib
import heapq
import math
import os
import random
import resource
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from operator import attrgetter
from pathlib import Path
from typing import Any

import edged_stw
from edged.records import ANGLE_MAX, Estimate, Measurement, validate_measurement
from edged_stw.config import StwConfig
from edged_stw.core import StwCore

SEED = 20261201
T0 = 1_764_576_000.0  # 2025-12-01T08:00Z
LAT0, LON0 = 54.0, 7.0  # German Bight, heading out into the North Sea
STW = 10.0  # m/s through the water
HEADING = math.radians(60.0)
CURRENT_SET, CURRENT_DRIFT = math.radians(150.0), 0.5
DVL_BIAS = 0.3
FORECAST_PERIOD = 1200.0

A_WGS84 = 6378137.0
E2_WGS84 = 6.69437999014e-3

# True velocity over ground = water velocity + current.
V_N = STW * math.cos(HEADING) + CURRENT_DRIFT * math.cos(CURRENT_SET)
V_E = STW * math.sin(HEADING) + CURRENT_DRIFT * math.sin(CURRENT_SET)
SOG, COG = math.hypot(V_N, V_E), math.atan2(V_E, V_N) % (2.0 * math.pi)

#: (label, kinds fed: (kind, source) pairs)
FULL = (("position", "gnss"), ("velocity_ground", "gnss"), ("heading", "gyro"), ("yaw_rate", "gyro"),
        ("accel_body", "imu"), ("yaw_rate", "imu"), ("water_speed", "log"), ("current", "forecast"))
MIXES = (
    ("reference suite (all 7 kinds)", FULL),
    ("no IMU", tuple(s for s in FULL if s[1] != "imu")),
    ("GNSS + gyro only", tuple(s for s in FULL if s[1] in ("gnss", "gyro"))),
    ("GNSS only", tuple(s for s in FULL if s[1] == "gnss")),
)


def _angle(a: float) -> float:
    a %= 2.0 * math.pi
    return min(a, ANGLE_MAX)


def _radii(lat: float) -> tuple[float, float]:
    """Metres per radian of latitude and of longitude at `lat` (WGS-84)."""
    s = math.sin(math.radians(lat))
    w = 1.0 - E2_WGS84 * s * s
    return A_WGS84 * (1.0 - E2_WGS84) / w**1.5, A_WGS84 / math.sqrt(w) * math.cos(math.radians(lat))


# -- the stream ---------------------------------------------------------------------
def _periodic(hz: float, seconds: float, rng: random.Random) -> Iterator[tuple[int, float]]:
    period = 1.0 / hz
    phase = rng.uniform(0.0, period)
    for k in range(int(round(seconds * hz))):
        yield k, T0 + phase + k * period


def _gnss(seconds: float, rng: random.Random) -> Iterator[Measurement]:
    lat, lon, t_prev = LAT0, LON0, T0
    for _, t in _periodic(10.0, seconds, rng):
        dt = t - t_prev  # one step of 0.1 s: the radii at the midpoint latitude
        lat_mid = lat + math.degrees(0.5 * V_N * dt / _radii(lat)[0])
        m, n = _radii(lat_mid)
        lat += math.degrees(V_N * dt / m)
        lon += math.degrees(V_E * dt / n)
        t_prev = t
        m, n = _radii(lat)
        yield Measurement("position", "gnss", t, {
            "lat": lat + math.degrees(rng.gauss(0.0, 2.5) / m),
            "lon": lon + math.degrees(rng.gauss(0.0, 2.5) / n),
            "fix_quality": 1, "hdop": 0.9, "sats": 12,
        })
        vn, ve = V_N + rng.gauss(0.0, 0.065), V_E + rng.gauss(0.0, 0.065)
        yield Measurement("velocity_ground", "gnss", t, {"sog": math.hypot(vn, ve), "cog": _angle(math.atan2(ve, vn))})


def _streams(seconds: float, seed: int, wanted: tuple[tuple[str, str], ...]) -> list[Iterator[Measurement]]:
    rng = random.Random(seed)  # one generator per stream, so a mix leaves out streams, not draws
    seeds = {s: rng.randrange(2**32) for s in ("gnss", "heading", "rot", "accel", "imu_rate", "log", "current")}
    r = {k: random.Random(v) for k, v in seeds.items()}
    g = r["heading"]
    heading = (Measurement("heading", "gyro", t, {"heading": _angle(HEADING + g.gauss(0.0, math.radians(0.5)))})
               for _, t in _periodic(10.0, seconds, g))
    rot = (Measurement("yaw_rate", "gyro", t, {"r": r["rot"].gauss(0.0, 0.001)}) for _, t in _periodic(10.0, seconds, r["rot"]))
    a = r["accel"]
    accel = (Measurement("accel_body", "imu", t, {"ax": a.gauss(0.0, 0.05), "ay": a.gauss(0.0, 0.05), "az": a.gauss(0.0, 0.05)})
             for _, t in _periodic(50.0, seconds, a))
    imu_rate = (Measurement("yaw_rate", "imu", t, {"r": r["imu_rate"].gauss(0.0, 0.001)})
                for _, t in _periodic(50.0, seconds, r["imu_rate"]))
    lg = r["log"]
    dvl = (Measurement("water_speed", "log", t, {"stw_long": STW + DVL_BIAS + lg.gauss(0.0, 0.1), "stw_trans": lg.gauss(0.0, 0.1)})
           for _, t in _periodic(1.0, seconds, lg))

    def forecasts() -> Iterator[Measurement]:
        c = r["current"]
        for _, t in _periodic(1.0 / FORECAST_PERIOD, seconds, c):
            cn = CURRENT_DRIFT * math.cos(CURRENT_SET) + c.gauss(0.0, 0.2)
            ce = CURRENT_DRIFT * math.sin(CURRENT_SET) + c.gauss(0.0, 0.2)
            yield Measurement("current", "forecast", t, {"set": _angle(math.atan2(ce, cn)), "drift": math.hypot(cn, ce)}, t_src=t)

    gnss = _gnss(seconds, r["gnss"])
    if ("position", "gnss") not in wanted:
        gnss = (m for m in gnss if m.kind != "position")
    by = {("heading", "gyro"): heading, ("yaw_rate", "gyro"): rot, ("accel_body", "imu"): accel,
          ("yaw_rate", "imu"): imu_rate, ("water_speed", "log"): dvl, ("current", "forecast"): forecasts()}
    out = [gnss] if ("position", "gnss") in wanted or ("velocity_ground", "gnss") in wanted else []
    return out + [it for key, it in by.items() if key in wanted]


def reference_blocks(seconds: float, block: float, seed: int = SEED,
                     wanted: tuple[tuple[str, str], ...] = FULL) -> Iterator[list[Measurement]]:
    """The suite in time order, lazily, as lists of `block` seconds of data each."""
    merged = heapq.merge(*_streams(seconds, seed, wanted), key=attrgetter("t"))
    checked: dict[tuple[str, str], int] = {}
    end = T0 + block
    out: list[Measurement] = []
    for m in merged:
        key = (m.kind, m.source)
        if checked.get(key, 0) < 200:  # the first records of each stream are valid edged records
            validate_measurement(m.kind, m.values)
            checked[key] = checked.get(key, 0) + 1
        while m.t >= end:
            yield out
            out = []
            end += block
        out.append(m)
    if out:
        yield out


# -- feeding a core -----------------------------------------------------------------
class Feed:
    """One core fed block by block; ticks on the k·(1/rate) grid as the worker host fires them."""

    def __init__(self, cfg: StwConfig, tick_rate: float | None) -> None:
        self.core = StwCore(cfg)
        self.period = None if not tick_rate else 1.0 / tick_rate
        self.k = math.floor(T0 / self.period) + 1 if self.period else 0
        self.steps = 0
        self.ticks = 0
        self.last: Estimate | None = None

    def run(self, block: list[Measurement]) -> float:
        """Feed one block; its CPU seconds (process_time)."""
        step, tick, period = self.core.step, self.core.tick, self.period
        k, n_ticks, last = self.k, 0, self.last
        cpu0 = time.process_time()
        if period is None:
            for m in block:
                step(m)
        else:
            for m in block:
                while k * period <= m.t:
                    est = tick(k * period)
                    if est:
                        last = est[-1]
                    k += 1
                    n_ticks += 1
                step(m)
        cpu = time.process_time() - cpu0
        self.k, self.last = k, last
        self.steps += len(block)
        self.ticks += n_ticks
        return cpu


def _numbers(v: Any) -> Iterator[Any]:
    if isinstance(v, dict):
        for x in v.values():
            yield from _numbers(x)
    elif isinstance(v, (list, tuple)):
        for x in v:
            yield from _numbers(x)
    else:
        yield v


class _NanWatch:
    """Wraps a core's tick so that every estimate it returns is checked (part 2)."""

    def __init__(self, core: StwCore) -> None:
        self.n = 0
        self.bad: list[tuple[float, str]] = []
        inner = core.tick

        def tick(t: float) -> list[Estimate]:
            out = inner(t)
            for e in out:
                self.n += 1
                for x in _numbers(e.values):
                    if isinstance(x, float) and not math.isfinite(x):
                        if len(self.bad) < 5:
                            self.bad.append((t, repr(e.values)))
                        break
            return out

        core.tick = tick  # type: ignore[method-assign]


def _blocks_in_memory(seconds: float, block: float, wanted: tuple[tuple[str, str], ...]) -> list[list[Measurement]]:
    return list(reference_blocks(seconds, block, wanted=wanted))


def steps_per_second(cfg: Callable[[], StwConfig], blocks: list[list[Measurement]], tick_rate: float | None,
                     runs: int) -> tuple[float, float, int]:
    rates = []
    n = sum(len(b) for b in blocks)
    for _ in range(runs):
        feed = Feed(cfg(), tick_rate)
        gc.collect()
        cpu = sum(feed.run(b) for b in blocks)
        rates.append(n / cpu)
    return max(rates), statistics.median(rates), n


def per_kind(blocks: list[list[Measurement]]) -> tuple[dict[str, list[float]], list[float]]:
    core = StwCore(StwConfig(type="stw"))
    pc = time.perf_counter
    out: dict[str, list[float]] = {}
    ticks: list[float] = []
    period = 1.0
    k = math.floor(T0) + 1
    for block in blocks:
        for m in block:
            while k * period <= m.t:
                t0 = pc()
                core.tick(k * period)
                ticks.append(pc() - t0)
                k += 1
            t0 = pc()
            core.step(m)
            dt = pc() - t0
            key = m.kind if m.kind != "yaw_rate" else f"yaw_rate ({m.source})"
            out.setdefault(key, []).append(dt)
    return out, ticks


def _rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# -- main -----------------------------------------------------------------------------
def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seconds", type=float, default=300.0, help="seconds of data per steps/s pass (default 300)")
    p.add_argument("--runs", type=int, default=3, help="passes per mix, best / median (default 3)")
    p.add_argument("--hours", type=float, default=24.0, help="hours of data in part 2 (default 24, 0 skips)")
    p.add_argument("--every", type=int, default=2, help="a progress line every this many hours of data (default 2)")
    p.add_argument("--block", type=float, default=60.0, help="seconds of data generated at a time (default 60)")
    args = p.parse_args()

    rate = sum(hz for hz in (10, 10, 10, 10, 50, 50, 1)) + 1.0 / FORECAST_PERIOD
    src = sorted(Path(edged_stw.__file__).parent.glob("*.py"))
    digest = hashlib.sha256(b"".join(f.read_bytes() for f in src)).hexdigest()[:12]
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, pid {os.getpid()}, seed {SEED}; "
          f"edged_stw sources sha256 {digest}")
    print(f"reference suite (DESIGN §9 without draft marks): {rate:.3f} measurements per s of data; "
          f"truth: STW {STW} m/s on {math.degrees(HEADING):.0f}°, current {CURRENT_DRIFT} m/s toward "
          f"{math.degrees(CURRENT_SET):.0f}°, SOG {SOG:.3f} m/s on {math.degrees(COG):.1f}°, log {DVL_BIAS} m/s high")
    print()
    print(f"1. StwCore.step (predict + update), {args.seconds:g} s of data per pass, {args.runs} passes, "
          "CPU (process_time), best / median")
    vector = lambda: StwConfig(type="stw")  # noqa: E731
    paper = lambda: StwConfig(type="stw", mode="paper")  # noqa: E731
    full_blocks = _blocks_in_memory(args.seconds, args.block, FULL)
    rows: list[tuple[str, Callable[[], StwConfig], list[list[Measurement]], float | None]] = []
    for label, wanted in MIXES:
        blocks = full_blocks if wanted is FULL else _blocks_in_memory(args.seconds, args.block, wanted)
        rows.append((f"{label}, vector", vector, blocks, None))
    rows.append(("reference suite, paper", paper, full_blocks, None))
    rows.append(("reference suite, vector, 1 Hz ticks", vector, full_blocks, 1.0))
    rows.append(("reference suite, paper, 1 Hz ticks", paper, full_blocks, 1.0))
    for label, cfg, blocks, tick_rate in rows:
        best, med, n = steps_per_second(cfg, blocks, tick_rate, args.runs)
        print(f"stw steps/s: {label:<38} {best:9,.0f} / {med:9,.0f}   ({1e6 / best:6.1f} µs per step, "
              f"{n / args.seconds:.0f} steps per s of data: RTF {best / (n / args.seconds):6.0f})", flush=True)
    kinds, ticks = per_kind(full_blocks)
    print("  per kind inside the reference suite (vector; per-call perf_counter, median / mean; the core averages\n"
          "  accel_body samples and updates with them at the next record of another kind, so the IMU's update\n"
          "  cost shows under the kind that follows it, mostly yaw_rate (imu)):")
    for key, xs in sorted(kinds.items(), key=lambda kv: -statistics.fmean(kv[1])):
        print(f"    {key:<20} {statistics.median(xs) * 1e6:6.1f} / {statistics.fmean(xs) * 1e6:6.1f} µs "
              f"({1.0 / statistics.fmean(xs):9,.0f} steps/s, {len(xs)} steps)")
    print(f"    {'tick (1 Hz)':<20} {statistics.median(ticks) * 1e6:6.1f} / {statistics.fmean(ticks) * 1e6:6.1f} µs "
          f"({len(ticks)} ticks)")
    del full_blocks, rows
    gc.collect()
    print(f"  peak RSS so far {_rss_mib():.0f} MiB")
    if args.hours <= 0:
        return
    print()
    seconds = args.hours * 3600.0
    print(f"2. {args.hours:g} h of the reference suite through one core (vector, ticks at 1 Hz), "
          f"generated lazily in {args.block:g} s blocks", flush=True)
    feed = Feed(StwConfig(type="stw"), 1.0)
    watch = _NanWatch(feed.core)
    cpu = 0.0
    wall0 = time.perf_counter()
    gen = 0.0
    hour = 0
    it = reference_blocks(seconds, args.block)
    while True:
        g0 = time.perf_counter()
        block = next(it, None)
        gen += time.perf_counter() - g0
        if block is None:
            break
        cpu += feed.run(block)
        if block[-1].t - T0 >= (hour + 1) * 3600.0:
            hour += 1
            if hour % args.every == 0:
                v = feed.last.values if feed.last is not None else {}
                print(f"    {hour:2d} h of data: {cpu:7.1f} s CPU so far, peak RSS {_rss_mib():.0f} MiB; "
                      f"stw {v.get('stw', math.nan):.3f} ± {v.get('stw_std', math.nan):.3f}, current "
                      f"{v.get('current', math.nan):.3f} toward {math.degrees(v.get('current_set') or 0.0):.0f}°, "
                      f"resets {feed.core.monitor.snapshot().get('resets')}", flush=True)
    wall = time.perf_counter() - wall0 - gen
    print(f"stw {args.hours:g} h reference suite: {cpu:.1f} s CPU (real-time factor {seconds / cpu:,.0f}); "
          f"wall {wall:.1f} s without the stream's generation ({gen:.1f} s) (RTF {seconds / wall:,.0f} per wall s); "
          f"{feed.steps:,} steps ({feed.steps / cpu:,.0f}/s), {feed.ticks:,} ticks; peak RSS {_rss_mib():.0f} MiB")
    last = feed.last
    if last is not None:
        v = last.values

        def f(key: str, fmt: str = ".3f") -> str:
            x = v.get(key)
            return "None" if x is None else format(x, fmt)

        print(f"  last estimate: stw {f('stw')} ± {f('stw_std')} m/s (truth {STW}), stw_long {f('stw_long')}, "
              f"stw_trans {f('stw_trans')}, current {f('current')} m/s toward "
              f"{'None' if v.get('current_set') is None else format(math.degrees(v['current_set']), '.0f')}° "
              f"(truth {CURRENT_DRIFT} toward {math.degrees(CURRENT_SET):.0f}°), dvl_bias {f('dvl_bias')} "
              f"(truth {DVL_BIAS}), dvl_stw {f('dvl_stw')}")
    h = feed.core.health()
    print(f"  health: missing {sorted(h.get('missing', {}))}, rejected {h.get('rejected')}, "
          f"resets {h.get('resets')}, warnings {h.get('warnings')}")
    print(f"  published estimates checked for NaN/inf: {watch.n:,}, bad: {len(watch.bad)}"
          + "".join(f"\n    t={t:.1f}: {s}" for t, s in watch.bad))


if __name__ == "__main__":
    main()
