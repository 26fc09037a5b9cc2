"""NMEA 2000 gateway log formats: records per second through read + decode, on one core.

Each real log of ../shared/data/n2k is read from memory by its format's reader and
every record decoded by the CAN decoder (`CanInput.make_decoder(...).decode`), as
`edged replay` does, repeated until at least `--seconds` of CPU time (the best
repetition counts). Yacht Devices RAW, Actisense plain and candump records are CAN
frames; an iKonvert record is a whole message (a fast-packet PGN is several bus
frames in one). The target is 20x NMEA 2000 bus saturation (1,700 frames/s) on one
core.

    .venv/bin/python tests/bench/bench_gateway_formats.py [--seconds S]
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged_can import candump
from edged_can.formats import actisense_plain, ikonvert, ydwg_raw
from edged_can.plugin import CanInput

SATURATION = 1700.0
DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "n2k"


def _ydwg(stream, health):
    return ydwg_raw.read(stream, "bench", health, ReplayOptions())


def _ikonvert(stream, health):
    return ikonvert.read(stream, "bench", health, ReplayOptions())


def _plain(stream, health):
    return actisense_plain.read(stream, "bench", health, ReplayOptions())


def _candump(stream, health):
    return candump.read(stream, "bench", health, bus_from_line=True)


CASES = [
    ("ydwg_raw", "canboat__samples__merrimac-ydwg-2020.raw", _ydwg, "frames"),
    ("ikonvert", "canboat__samples__ikonvert.log", _ikonvert, "messages"),
    ("actisense_plain", "canboat__samples__dirona-actisense-serial.raw", _plain, "frames"),
    ("candump -l", "canboat__samples__can0-1.pcap__DERIVED_candump-l.log", _candump, "frames"),
]


def run_once(data: bytes, reader) -> tuple[int, int, float]:
    health = ComponentHealth("bench", "input", "can", ManualClock(0.0))
    decoder = CanInput.make_decoder("bench", None, health)
    decode = decoder.decode
    n = m = 0
    t0 = time.process_time()
    for raw in reader(io.BytesIO(data), health):
        n += 1
        m += len(decode(raw))
    return n, m, time.process_time() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="CPU time per format (default 2)")
    args = ap.parse_args()
    if not DATA.is_dir():
        print(f"{DATA} absent: nothing to measure")
        return 0
    print(f"{'format':<16} {'file':<52} {'records':>8} {'meas.':>7} {'per second':>20}  x saturation")
    for name, fname, reader, unit in CASES:
        path = DATA / fname
        if not path.is_file():
            print(f"{name:<16} {fname:<52} absent")
            continue
        data = path.read_bytes()
        best = float("inf")
        spent = 0.0
        reps = 0
        while spent < args.seconds or reps < 3:
            n, m, dt = run_once(data, reader)
            best = min(best, dt)
            spent += dt
            reps += 1
        rate = n / best
        print(f"{name:<16} {fname:<52} {n:>8} {m:>7} {rate:>9,.0f} {unit}/s  {rate / SATURATION:.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
