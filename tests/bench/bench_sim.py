"""Benchmark of `edged sim`: 3 hours of each stw-* scenario must take under 30 s.

Run: .venv/bin/python tests/bench/bench_sim.py [--hours H]
Prints wall time per scenario (integration + sensors + encoding + writing files) and
the record rates; also a 10-minute run of the full reference suite (draft-squat).
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

from edged_sim.run import Simulation
from edged_sim.scenarios import SCENARIOS
from edged_sim.writers import write_run


def bench(name: str, duration: float) -> float:
    out = Path(tempfile.mkdtemp(prefix="bench_sim_"))
    try:
        t0 = time.perf_counter()
        meta = write_run(Simulation(SCENARIOS[name], seed=1, duration=duration), out)
        wall = time.perf_counter() - t0
        size = sum(f.stat().st_size for f in out.iterdir()) / 1e6
    finally:
        shutil.rmtree(out)
    records = meta["files"]["nmea.log"] + meta["files"]["can.log"]
    print(f"{name:24s} {duration:8.0f} s simulated in {wall:6.2f} s wall "
          f"({duration / wall:7.0f}x real time), {records:9d} records ({records / wall:8.0f}/s), {size:6.1f} MB")
    return wall


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--hours", type=float, default=3.0)
    a = ap.parse_args()
    for name in ("stw-astern-current", "stw-cross-current"):
        wall = bench(name, a.hours * 3600.0)
        print(f"  target < 30 s for 3 h: {'OK' if wall * 3.0 / a.hours < 30.0 else 'TOO SLOW'}")
    bench("draft-squat", 600.0)


if __name__ == "__main__":
    main()
