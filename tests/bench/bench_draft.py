"""Benchmark: the draft estimator's cost, in the core and in a replay.

    .venv/bin/python tests/bench/bench_draft.py [--seconds 300] [--runs 3] [--hours 1] [--out DIR]
                                                [--mode adaptive|paper] [--no-compare]

1. The core: `--seconds` of `draft-harbour` (seed 1) simulated, its can.log decoded
   in-process with the decoders `edged replay` uses (tests/support/manoeuvre_data.py),
   the six marks' readings (100 Hz each: 600 readings per second of data) fed to
   `edged_draft.core.DraftCore(DraftConfig(type="draft", stw_from=None))` by `.step(m)`,
   with `.tick(t)` at 1 Hz fired before the first reading at or after each whole second
   (as the worker host ticks). Process CPU time (time.process_time) of step + tick only,
   best and median of `--runs` passes with a fresh core each: µs per reading and the
   CPU share of one core that 600 readings/s take (CPU s per s of data).
2. A replay: `--hours` of `draft-harbour` (`edged sim --duration`, cached in `--out`)
   replayed with `[estimators.stw]` and `[estimators.draft]` (the vessel's figures; the
   draft estimator in a process of its own, its default), `--no-zenoh --no-progress
   --record run.mcap`: wall time, CPU time (this process and its children) and the
   real-time factor (target ≥ 50×); and, unless `--no-compare`, the same replay with
   the draft estimator in the event loop (`worker = "loop"`) and with
   `[estimators.stw]` alone, so that the draft estimator's share of the replay shows.

Not a pytest test (no `test_` prefix): run it on demand.
"""

from __future__ import annotations

import argparse
import gc
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "support"))

from edged_draft.config import DraftConfig  # noqa: E402
from edged_draft.core import DraftCore  # noqa: E402
from manoeuvre_data import measurements  # noqa: E402

EDGED = [sys.executable, "-m", "edged.cli"]
SIM_FILES = ("nmea.log", "can.log", "truth.csv", "meta.json")
TARGET_RTF = 50.0
PARTICULARS = ('mark_spacing = 225.0\nbeam = 32.2\nblock_coefficient = 0.85\ntransducer_x = 67.5\n'
               'transducer_height = 0.0\n')  # draft-harbour's bulk carrier (score_draft.py takes them from meta)


def simulate(out: Path, seconds: float, seed: int = 1) -> Path:
    d = out / f"draft-harbour-{seed}-{seconds:g}s"
    if not all((d / f).exists() for f in SIM_FILES):
        subprocess.run(EDGED + ["sim", "draft-harbour", "--out", str(d), "--seed", str(seed),
                                "--duration", str(seconds)], check=True, capture_output=True)
    return d


def feed(ms: list, mode: str) -> tuple[float, int, int]:
    """CPU seconds of step + tick over the readings, readings fed, estimates out."""
    core = DraftCore(DraftConfig(type="draft", stw_from=None, mode=mode))
    step, tick = core.step, core.tick
    next_tick = float(int(ms[0].t) + 1)
    n_est = 0
    gc.collect()
    gc.disable()
    try:
        c0 = time.process_time()
        for m in ms:
            while m.t >= next_tick:
                n_est += len(tick(next_tick))
                next_tick += 1.0
            step(m)
        c1 = time.process_time()
    finally:
        gc.enable()
    return c1 - c0, len(ms), n_est


def bench_core(out: Path, seconds: float, runs: int, mode: str) -> None:
    d = simulate(out, seconds)
    t = time.perf_counter()
    ms = [m for m in measurements([d / "can.log"]) if m.kind == "draft"]
    decode_s = time.perf_counter() - t
    span = ms[-1].t - ms[0].t
    marks = len({m.values["mark"] for m in ms})
    print(f"\n## 1. DraftCore ({mode}): {len(ms)} readings of {marks} marks over {span:.0f} s of draft-harbour "
          f"({len(ms) / span:.0f} readings/s; decoded in {decode_s:.1f} s, outside the timing)")
    cpu = []
    for _ in range(runs):
        c, n, n_est = feed(ms, mode)
        cpu.append(c)
    best, med = min(cpu), statistics.median(cpu)
    print("| pass | CPU s | µs / reading | CPU s per s of data | share of one core |")
    print("|---|---|---|---|---|")
    for label, c in (("best", best), ("median", med)):
        print(f"| {label} of {runs} | {c:.2f} | {1e6 * c / n:.1f} | {c / span:.4f} | {100 * c / span:.1f} % |")
    print(f"({n_est} estimates from the ticks)")


def replay(d: Path, name: str, config: str) -> tuple[float, float]:
    cfg = d / f"{name}.toml"
    cfg.write_text(config)
    rec = d / f"{name}.mcap"
    cmd = EDGED + ["replay", "-c", str(cfg), str(d / "nmea.log"), str(d / "can.log"), "--no-zenoh", "--no-progress",
                   "--record", str(rec)]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f"replay failed ({p.returncode}): {shlex.join(cmd)}\n{p.stderr[-2000:]}")
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def bench_replay(out: Path, hours: float, compare: bool) -> None:
    seconds = hours * 3600.0
    t = time.perf_counter()
    d = simulate(out, seconds)
    sim_s = time.perf_counter() - t
    size = sum((d / f).stat().st_size for f in ("nmea.log", "can.log")) / 1e6
    print(f"\n## 2. Replay of {hours:g} h of draft-harbour with recording ({size:.0f} MB of logs; sim {sim_s:.0f} s "
          f"or cached)")
    stw = '[estimators.stw]\ntype = "stw"\n'
    draft = stw + '\n[estimators.draft]\ntype = "draft"\n' + PARTICULARS
    runs = [("stw + draft (draft in its process)", "stw_draft", draft)]
    if compare:
        runs.append(("stw + draft (draft in the loop)", "stw_draft_loop", draft + 'worker = "loop"\n'))
        runs.append(("stw alone", "stw_only", stw))
    print("| estimators | wall s | CPU s | × real time | target |")
    print("|---|---|---|---|---|")
    walls = {}
    for label, name, cfg in runs:
        wall, cpu = replay(d, name, cfg)
        walls[name] = wall
        rtf = seconds / wall
        target = f"≥ {TARGET_RTF:g}×: {'met' if rtf >= TARGET_RTF else 'NOT met'}" if name == "stw_draft" else ""
        print(f"| {label} | {wall:.1f} | {cpu:.1f} | {rtf:.1f}× | {target} |")
    if compare:
        for name, where in (("stw_draft", "in its process"), ("stw_draft_loop", "in the loop")):
            extra = walls[name] - walls["stw_only"]
            print(f"(the draft estimator {where} adds {extra:.1f} s of wall time: "
                  f"{1e6 * extra / (600 * seconds):.1f} µs per reading in the replay)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=300.0, help="data for part 1 (s)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--hours", type=float, default=1.0, help="replay length for part 2 (0 skips it)")
    ap.add_argument("--mode", choices=("adaptive", "paper"), default="adaptive")
    ap.add_argument("--no-compare", action="store_true", help="no replay with the STW estimator alone")
    ap.add_argument("--numpy", action="store_true",
                    help="part 1 on the numpy path (the default install's: numba is the optional extra `fast`)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    start = time.perf_counter()
    out = a.out or Path(tempfile.mkdtemp(prefix="bench_draft-"))
    out.mkdir(parents=True, exist_ok=True)
    if a.numpy:
        from edged_draft import waves
        waves._KERNEL = None  # as when numba is not installed
        print("part 1 on the numpy path (numba not used)")
    bench_core(out, a.seconds, a.runs, a.mode)
    if a.hours > 0:
        bench_replay(out, a.hours, not a.no_compare)
    print(f"\nfiles in {out}")
    print(f"command: {shlex.join([Path(sys.executable).name, *sys.argv])}")
    print(f"wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
