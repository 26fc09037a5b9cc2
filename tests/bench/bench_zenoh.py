"""Benchmark of the Zenoh output: throughput and cross-process latency.

    .venv/bin/python tests/bench/bench_zenoh.py [--seconds 10]

1. Throughput: how many records per second `ZenohOutput.write` publishes (route, JSON
   encode, put) with a subscriber in another process receiving them.
2. Latency: the reference load of DESIGN §9 (six draft marks at 100 Hz, IMU
   accelerations and rates at 50 Hz, GNSS position and SOG/COG at 10 Hz, heading and
   rate of turn at 10 Hz, the log at 1 Hz) written in real time with every measurement
   published (rate limit lifted), timed from the `write` call to the moment the
   subscriber process has the sample (CLOCK_MONOTONIC is shared by processes on Linux).
3. The same load with the default 10 Hz measurement limit: what actually goes on the
   wire.

zenoh batches small messages for up to 1 ms by default (`transport/link/tx/queue/batching/
time_limit`), which is most of the latency: try `--zenoh-config` with a file saying
`{transport: {link: {tx: {queue: {batching: {time_limit: 0}}}}}}` to see the difference.

The script runs itself with `--subscriber` as the receiving process.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

import zenoh

T0 = 1_732_350_000.0
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")


# -- subscriber process ------------------------------------------------------------
def subscriber(prefix: str, connect: str) -> int:
    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"peer"')
    cfg.insert_json5("listen/endpoints", "[]")
    cfg.insert_json5("connect/endpoints", json.dumps([connect]))
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("scouting/gossip/enabled", "false")
    s = zenoh.open(cfg)
    got: list[tuple[str, float, float]] = []
    done = threading.Event()
    mono = time.monotonic

    def on(sample: zenoh.Sample) -> None:
        now = mono()
        key = str(sample.key_expr)
        if key.endswith("/est/end"):
            done.set()
            return
        got.append((key, json.loads(sample.payload.to_bytes())["t"], now))

    alive = threading.Event()
    sub = s.declare_subscriber(f"{prefix}/**", on)
    live = s.liveliness().declare_subscriber(f"{prefix}/alive", lambda smp: alive.set(), history=True)
    alive.wait(30)
    for _ in s.get(f"{prefix}/**", timeout=10):
        pass
    print("ready", flush=True)
    for line in sys.stdin:
        if line.strip() == "dump":
            done.wait(60)
            print(json.dumps(got), flush=True)
            got.clear()
            done.clear()
        elif line.strip() == "quit":
            break
    live.undeclare()
    sub.undeclare()
    s.close()
    return 0


# -- publishing side ---------------------------------------------------------------
def reference_load(seconds: float):
    """(t, records) per 10 ms tick of the DESIGN §9 suite, in data time."""
    from edged.records import Measurement

    ticks = int(seconds * 100)
    for k in range(ticks):
        t = T0 + k * 0.01
        recs = [
            Measurement("draft", f"can0.DraftMark.{m}", t, {"mark": m, "draft": 7.0 + 0.01 * i, "status": 0})
            for i, m in enumerate(MARKS)
        ]
        if k % 2 == 0:
            recs.append(Measurement("accel_body", "can0.ImuAccel", t, {"ax": 0.01, "ay": -0.02, "az": 0.0}))
            recs.append(Measurement("yaw_rate", "can0.ImuRate", t, {"r": 0.001}))
        if k % 10 == 0:
            recs.append(Measurement("position", "gnss1", t, {"lat": 60.1, "lon": 24.9, "fix_quality": 1, "hdop": 0.9, "sats": 9}))
            recs.append(Measurement("velocity_ground", "gnss1", t, {"sog": 6.1, "cog": 1.2}))
            recs.append(Measurement("heading", "gyro", t, {"heading": 1.21}))
            recs.append(Measurement("yaw_rate", "gyro", t, {"r": 0.0012}))
        if k % 100 == 0:
            recs.append(Measurement("water_speed", "log", t, {"stw_long": 6.0, "stw_trans": 0.1}))
        yield t, recs


def _port() -> int:
    with socket.socket() as so:
        so.bind(("127.0.0.1", 0))
        return so.getsockname()[1]


def _ctx(vessel: str):
    from edged.clock import ManualClock
    from edged.health import ComponentHealth
    from edged.plugin import PluginContext

    clock = ManualClock(T0)
    return PluginContext("zenoh", clock, ComponentHealth("zenoh", "output", "zenoh", clock), lambda r: None, vessel)


def _pct(xs: list[float], p: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(p / 100.0 * len(xs)))]


async def bench(seconds: float, zenoh_config: str | None) -> None:
    from edged.records import Estimate
    from edged_zenoh.output import ZenohOutput, ZenohOutputConfig

    port = _port()
    results = {}
    for label, limit in (("all measurements", {k: 1000.0 for k in ("draft", "accel_body", "yaw_rate", "position",
                                                                    "velocity_ground", "heading", "water_speed")}),
                         ("default 10 Hz limit", {})):
        ctx = _ctx("bench")
        out = ZenohOutput(
            ZenohOutputConfig.model_validate(
                {"type": "zenoh", "listen": [f"tcp/127.0.0.1:{port}"], "meas_max_hz": limit,
                 **({"zenoh_config": zenoh_config} if zenoh_config else {})}
            ),
            ctx,
        )
        await out.open()
        await asyncio.wait_for(out.connected.wait(), 30)
        out.write([Estimate("hello", "b", T0, {})])
        sub = subprocess.Popen(
            [sys.executable, __file__, "--subscriber", "--connect", f"tcp/127.0.0.1:{port}"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        )
        assert sub.stdout.readline().strip() == "ready"

        if label == "all measurements":
            # 1. Throughput: estimates of the size of est/manoeuvre, as fast as write goes.
            values = {"lat": 60.1, "lon": 24.9, "x": 1.0, "y": 2.0, "u": 6.1, "v": 0.1, "r": 0.001, "heading": 1.2,
                      "a_u": 0.0, "a_v": 0.0, "sog": 6.1, "cog": 1.2, "drift_angle": 0.01, "nis": 1.1}
            n = 100_000
            batch = [Estimate("manoeuvre", "m", T0 + i * 0.01, values) for i in range(n)]
            t_start = time.perf_counter()
            for i in range(0, n, 1000):
                out.write(batch[i:i + 1000])
            dt = time.perf_counter() - t_start
            out.write([Estimate("end", "b", T0, {})])
            sub.stdin.write("dump\n")
            sub.stdin.flush()
            received = len(json.loads(sub.stdout.readline()))
            print(f"throughput: {n / dt:,.0f} records/s through write+put "
                  f"({len(json.dumps({'t': T0, **values}))} B JSON each); subscriber received {received}/{n}")

        # 2./3. Reference load in real time.
        sent: dict[tuple[str, float], float] = {}
        start = time.monotonic()
        nrec = 0
        for k, (t, recs) in enumerate(reference_load(seconds)):
            due = start + k * 0.01
            delay = due - time.monotonic()
            if delay > 0:
                await asyncio.sleep(delay)
            now = time.monotonic()
            for r in recs:
                sent[(f"vessel/bench/meas/{r.kind}/{r.source}", r.t)] = now
            out.write(recs)
            nrec += len(recs)
        wall = time.monotonic() - start
        out.write([Estimate("end", "b", T0, {})])
        sub.stdin.write("dump\n")
        sub.stdin.flush()
        got = json.loads(sub.stdout.readline())
        lat = [(rx - sent[(key, t)]) * 1e3 for key, t, rx in got if (key, t) in sent]
        results[label] = (nrec, len(got), lat)
        print(f"{label}: {nrec} records in {wall:.1f} s ({nrec / wall:.0f}/s offered), "
              f"{len(got)} received ({len(got) / wall:.0f}/s), "
              f"latency p50 {_pct(lat, 50):.3f} ms, p99 {_pct(lat, 99):.3f} ms, max {max(lat):.3f} ms, "
              f"mean {statistics.fmean(lat):.3f} ms")
        sub.stdin.write("quit\n")
        sub.stdin.flush()
        sub.wait(30)
        await out.close()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--subscriber", action="store_true")
    ap.add_argument("--connect")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--zenoh-config", help="json5 merged over the output's defaults, e.g. batching settings")
    a = ap.parse_args()
    if a.subscriber:
        return subscriber("vessel/bench", a.connect)
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    asyncio.run(bench(a.seconds, a.zenoh_config))
    return 0


if __name__ == "__main__":
    sys.exit(main())
