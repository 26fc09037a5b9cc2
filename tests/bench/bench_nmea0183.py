"""Benchmark: the NMEA 0183 input stage against bare pynmea2 on the same sentences.

Run: .venv/bin/python tests/bench/bench_nmea0183.py [N_CYCLES]

Writes a log of GGA/VTG/HDT/VBW cycles (10 Hz GNSS and heading, VBW each cycle) to a
temporary file, then times
  1. bare `pynmea2.parse(line, check=True)` of every line (the floor, DEPENDENCIES.md);
  2. the full input stage: reading the file, framing, checksum, time stamping, raw
     records, decoding to validated measurements (`NMEA0183.open` + `decode`).
Prints both rates in sentences/s and their cost ratio (target: <= 1.5).
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from functools import reduce
from operator import xor

import pynmea2

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged_nmea0183.logs import NMEA0183
from edged_nmea0183.plugin import Nmea0183Input


ROUNDS = 5


def _line(body: str) -> str:
    return "$%s*%02X" % (body, reduce(xor, body.encode(), 0))


def make_log(n_cycles: int) -> list[str]:
    lines = []
    for i in range(n_cycles):
        s = i // 10
        hh, mm, ss = (s // 3600) % 24, (s // 60) % 60, s % 60
        frac = (i % 10) / 10
        ts = f"{hh:02d}{mm:02d}{ss + frac:05.2f}"
        lat = 5230.0 + (i % 1000) * 1e-4
        lines.append(_line(f"GPGGA,{ts},{lat:.4f},N,00430.1234,E,1,12,0.8,5.0,M,46.0,M,,"))
        lines.append(_line(f"GPVTG,{(i % 3600) / 10:.1f},T,,M,{6 + (i % 7) / 10:.1f},N,{11 + (i % 7) / 10:.1f},K,A"))
        lines.append(_line(f"HEHDT,{(i % 3600) / 10:.1f},T"))
        lines.append(_line(f"VDVBW,{6 + (i % 5) / 10:.2f},0.12,A,{6.1 + (i % 5) / 10:.2f},0.10,A"))
    return lines


def bench_pynmea2(lines: list[str]) -> float:
    parse = pynmea2.parse
    t0 = time.perf_counter()
    for line in lines:
        parse(line, check=True)
    return time.perf_counter() - t0


def bench_stage(path: str) -> tuple[float, int, dict[str, int]]:
    health = ComponentHealth("bench", "input", "nmea0183", ManualClock())
    decoder = Nmea0183Input.make_decoder("bench", None, health)
    decode = decoder.decode
    n_meas = 0
    t0 = time.perf_counter()
    with open(path, "rb") as f:
        for raw in NMEA0183.open(f, "bench", health, ReplayOptions(date="2024-06-01")):
            n_meas += len(decode(raw))
    return time.perf_counter() - t0, n_meas, health.counters


def main() -> int:
    n_cycles = int(sys.argv[1]) if len(sys.argv) > 1 else 50_000
    lines = make_log(n_cycles)
    with tempfile.NamedTemporaryFile("w", suffix=".nmea", delete=False) as f:
        f.write("\r\n".join(lines) + "\r\n")
        path = f.name
    try:
        # Alternate the two, best of each: on a shared machine the load changes between
        # runs, and interleaving exposes both to the same conditions.
        bare_times, runs = [], []
        for _ in range(ROUNDS):
            bare_times.append(bench_pynmea2(lines))
            runs.append(bench_stage(path))
        best_bare = min(bare_times)
        best_stage = min(r[0] for r in runs)
        _, n_meas, counters = runs[0]
    finally:
        os.unlink(path)
    n = len(lines)
    assert counters.get("accepted") == n, counters
    print(f"sentences: {n} (GGA/VTG/HDT/VBW), measurements: {n_meas}")
    print(f"bare pynmea2.parse(check=True): {n / best_bare:10.0f} sentences/s  ({best_bare / n * 1e6:.2f} us each)")
    print(f"full input stage:               {n / best_stage:10.0f} sentences/s  ({best_stage / n * 1e6:.2f} us each)")
    ratio = best_stage / best_bare
    print(f"cost ratio stage / bare pynmea2: {ratio:.2f} (target <= 1.5): {'OK' if ratio <= 1.5 else 'OVER'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
