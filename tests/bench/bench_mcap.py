"""Benchmark: records per second through the MCAP recorder at the reference load (DESIGN §9).

One second of data: six draft marks at 100 Hz, IMU accelerations and rates at 50 Hz,
GNSS position and SOG/COG at 10 Hz, heading and rate of turn at 10 Hz, the Doppler log
at 1 Hz (raw frame or sentence plus its measurement each), a position also written as
a LocationFix, three estimates at 10 Hz and health at 1 Hz. Records go in in batches
of 1024 (the runtime's batch), with a flush at every second of data: the runtime
flushes once per wall second, so this flushes far more often than the daemon would.

Run: .venv/bin/python tests/bench/bench_mcap.py [--seconds 120]
"""

from __future__ import annotations

import argparse
import asyncio
import random
import tempfile
import time
from pathlib import Path
from typing import Any

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.records import Estimate, HealthRecord, Measurement, RawRecord
from edged_mcap.recorder import McapRecorder

T0 = 1_732_350_000.0
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")


def one_second(s: int, rnd: random.Random) -> list[Any]:
    out: list[Any] = []
    base = T0 + s

    def can(t: float, fid: int, n: int) -> None:
        out.append(RawRecord("can", "can0", t, rnd.randbytes(n), {"id": fid, "ext": False}))

    def nmea(t: float, line: bytes) -> None:
        out.append(RawRecord("nmea0183", "gnss1", t, line, None))

    for i in range(100):
        t = base + i / 100
        for k, mark in enumerate(MARKS):
            can(t, 0x310 + k, 4)
            out.append(Measurement("draft", "can0.DraftMark", t, {"mark": mark, "draft": 8 + rnd.random(), "status": 0}))
    for i in range(50):
        t = base + i / 50
        can(t, 0x320, 6)
        out.append(Measurement("accel_body", "can0.ImuAccel", t, {"ax": rnd.random(), "ay": rnd.random(), "az": 0.0}))
        can(t, 0x321, 8)
        out.append(Measurement("yaw_rate", "can0.ImuRate", t, {"r": rnd.random() * 0.01}))
    for i in range(10):
        t = base + i / 10
        nmea(t, b"$GPGGA,082000.00,6005.00000,N,02330.00000,E,1,08,0.9,5.0,M,17.0,M,,*5C\r\n")
        out.append(Measurement("position", "gnss1", t, {"lat": 60.08, "lon": 23.5, "fix_quality": 1, "hdop": 0.9, "sats": 8}))
        nmea(t, b"$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48\r\n")
        out.append(Measurement("velocity_ground", "gnss1", t, {"sog": 2.83, "cog": 0.955}))
        nmea(t, b"$HEHDT,054.1,T*1B\r\n")
        out.append(Measurement("heading", "gyro", t, {"heading": 0.944}))
        nmea(t, b"$HEROT,0.5,A*3A\r\n")
        out.append(Measurement("yaw_rate", "gyro", t, {"r": 1.4e-4}))
        out.append(Estimate("stw", "stw", t, {"stw": 2.8, "stw_std": 0.05, "sog": 2.83, "current": 0.1, "distance": 1.0, "dvl_stw": 2.79, "stw_long": 2.8, "stw_trans": 0.01, "mode": "full"}))
        out.append(Estimate("manoeuvre", "manoeuvre", t, {"lat": 60.08, "lon": 23.5, "x": 0.0, "y": 0.0, "u": 2.8, "v": 0.02, "r": 1e-4, "heading": 0.944, "a_u": 0.0, "a_v": 0.0, "sog": 2.83, "cog": 0.955, "drift_angle": 0.007, "nis": 1.2, "model": "cruise", "filter": "ekf", "std": {"u": 0.05, "v": 0.05, "r": 1e-4}}))
        out.append(Estimate("draft", "draft", t, {"marks": {m: {"draft": 8.0, "mean": 8.0, "rate": 0.0, "amplitude": 0.1, "std": 0.01} for m in MARKS}, "mean_draft": 8.0, "trim": 0.1, "list": 0.0, "heel": None, "deflection": 0.0, "squat": None, "ukc": None}))
    nmea(base, b"$VDVBW,5.4,0.1,A,5.5,0.1,A*54\r\n")
    out.append(Measurement("water_speed", "dvl", base, {"stw_long": 2.78, "stw_trans": 0.05}))
    out.append(HealthRecord(base, {"t": base, "outputs": {"rec": {"state": "recording", "counters": {"recorded": s}}}}))
    out.sort(key=lambda r: r.t)
    return out


def run(seconds: int, fsync: bool, compression: str, folder: Path) -> dict[str, float]:
    rnd = random.Random(0)
    data = [one_second(s, rnd) for s in range(seconds)]
    clock = ManualClock(T0)
    health = ComponentHealth("rec", "output", "mcap", clock)
    ctx = PluginContext("rec", clock, health, lambda r: None, vessel_id="bench")
    path = folder / f"bench-{compression}-{fsync}.mcap"
    cfg = McapRecorder.Config.model_validate({"type": "mcap", "path": str(path), "fsync": fsync, "compression": compression})
    rec = McapRecorder(cfg, ctx)
    asyncio.run(rec.open())
    n_records = sum(len(d) for d in data)
    start = time.perf_counter()
    for sec in data:
        for i in range(0, len(sec), 1024):
            rec.write(sec[i : i + 1024])
        clock.step(1.0)
        rec.flush()
    asyncio.run(rec.close())
    wall = time.perf_counter() - start
    msgs = health.counters["recorded"]
    return {
        "records": n_records,
        "messages": msgs,
        "wall": wall,
        "records_per_s": n_records / wall,
        "messages_per_s": msgs / wall,
        "rtf": seconds / wall,
        "bytes_per_msg": path.stat().st_size / msgs,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=int, default=120, help="seconds of reference data")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for compression, fsync in (("zstd", False), ("zstd", True), ("lz4", False), ("none", False)):
            r = run(args.seconds, fsync, compression, Path(tmp))
            print(
                f"compression={compression:<4} fsync={str(fsync):<5}  {r['records'] / args.seconds:.0f} records/s of data"
                f" -> {r['messages_per_s']:,.0f} messages/s ({r['records_per_s']:,.0f} records/s),"
                f" real-time factor {r['rtf']:.0f}, {r['bytes_per_msg']:.1f} B/message"
            )


if __name__ == "__main__":
    main()
