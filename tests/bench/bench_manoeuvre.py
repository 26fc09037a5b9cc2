"""Manoeuvring-state estimator: cost per update of each model × filter, and the share of
a core it takes live on the reference sensor suite.

    .venv/bin/python tests/bench/bench_manoeuvre.py [--seconds 300] [--members 25,50,100,200]
        [--only default] [--repeat 1]

The measurements are a simulated `manoeuvre-williamson` run (`edged sim`, seed 1) with
the reference suite of DESIGN §9 (GNSS and gyro at 10 Hz, IMU at 50 Hz), decoded as
`edged replay` decodes them, one source per kind as the worker host picks them. Each
combination is fed the first `--seconds` of it with 10 Hz ticks (publishing and the
1 Hz prediction included) and timed in CPU time. Printed per combination: µs per
measurement fed, µs per filter update (predict to the measurement's time + update;
sensors faster than 10 Hz are averaged first, so there are fewer updates than
measurements), the real-time factor, and the share of one core live. Seed 004 allows
0.1 s a step for a real-time estimator: the last column is the update time against it.
`--only` keeps the combinations whose name holds one of its comma-separated words (the
default row alone: `--only default`); `--repeat` times each that many times and prints
the fastest (the machine's speed drifts: compare runs made back to back).
"""

from __future__ import annotations

import argparse
import math
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))

from manoeuvre_data import measurements, select  # noqa: E402

from edged_manoeuvre.config import ManoeuvreConfig  # noqa: E402
from edged_manoeuvre.core import ManoeuvreCore  # noqa: E402

SOURCES = {"position": "nmea", "heading": "nmea", "yaw_rate": "can0.ImuRate", "accel_body": "can0.ImuAccel"}


def _data(seconds: float) -> list:
    cache = Path(tempfile.gettempdir()) / "edged-bench-manoeuvre"
    pkl = cache / "ms.pkl"
    if not pkl.is_file():
        cache.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-m", "edged.cli", "sim", "manoeuvre-williamson", "--out", str(cache),
                        "--seed", "1"], check=True, capture_output=True)
        ms = measurements([cache / "nmea.log", cache / "can.log"])
        pkl.write_bytes(pickle.dumps(ms))
    ms = pickle.loads(pkl.read_bytes())
    ms = select(ms, SOURCES, SOURCES)
    t0 = ms[0].t
    return [m for m in ms if m.t - t0 <= seconds]


def run(ms: list, **kw) -> tuple[float, int, int, float]:
    core = ManoeuvreCore(ManoeuvreConfig(type="manoeuvre", **kw))
    nxt = math.floor(ms[0].t * 10) / 10 + 0.1
    c0 = time.process_time()
    for m in ms:
        while m.t >= nxt - 1e-9:
            core.tick(nxt)
            nxt = round(nxt + 0.1, 6)
        core.step(m)
    cpu = time.process_time() - c0
    updates = sum(k["updates"] + k["gated"] for k in core.health()["innovation"].values())
    return cpu, len(ms), updates, ms[-1].t - ms[0].t


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=300.0, help="seconds of the voyage fed to each (default 300)")
    ap.add_argument("--members", default="25,50,100,200", help="EnKF ensemble sizes")
    ap.add_argument("--only", default="", help="comma-separated words: only the combinations named with one")
    ap.add_argument("--repeat", type=int, default=1, help="time each this many times, print the fastest")
    args = ap.parse_args()
    ms = _data(args.seconds)
    combos: list[tuple[str, dict]] = [
        ("ctra+ekf (default)", {}),
        ("ctra+ekf, every sample", {"max_rate": 0.0}),
        ("cmm+ekf", {"model": "cmm"}),
        ("ctra+ukf", {"filter": "ukf"}),
        ("cmm+ukf", {"model": "cmm", "filter": "ukf"}),
    ] + [(f"ctra+enkf N={n}", {"filter": "enkf", "members": int(n)}) for n in args.members.split(",")]
    combos.append(("ctra+ekf, paper mode", {"mode": "paper"}))
    words = [w for w in args.only.split(",") if w]
    combos = [(name, kw) for name, kw in combos if not words or any(w in name for w in words)]
    print(f"{len(ms)} measurements over {ms[-1].t - ms[0].t:.0f} s ({len(ms) / (ms[-1].t - ms[0].t):.0f}/s), "
          f"sources {SOURCES}")
    print(f"{'combination':<26} {'µs/meas':>8} {'updates/s':>9} {'µs/update':>9} {'real-time x':>11} "
          f"{'core live':>9} {'of 0.1 s':>9}")
    for name, kw in combos:
        cpu, n, updates, span = min(run(ms, **kw) for _ in range(max(args.repeat, 1)))
        per_update = cpu / max(updates, 1)
        print(f"{name:<26} {1e6 * cpu / n:>8.1f} {updates / span:>9.0f} {1e6 * per_update:>9.1f} "
              f"{span / cpu:>11.0f} {100 * cpu / span:>8.2f}% {100 * per_update / 0.1:>8.3f}%")
    return 0


if __name__ == "__main__":
    sys.exit(main())
