"""Benchmark: latency from `Runtime.router.publish` to a subscriber in another process.

    .venv/bin/python tests/bench/bench_latency.py [--seconds 10]

A live `Runtime` (LiveClock, no inputs) with the zenoh output, fed by an asyncio program
paced at the reference load of DESIGN §9: six draft marks at 100 Hz, IMU accelerations
and rates at 50 Hz each, GNSS position and SOG/COG at 10 Hz, heading and rate of turn at
10 Hz, the log at 1 Hz (~740 measurements/s). Each measurement's `t` is the LiveClock's
time at the moment it is published; the subscriber (same machine) takes `time.time() - t`
at receipt. Whole path: router queue, output task, JSON, zenoh put, TCP loopback, the
subscriber's zenoh thread.

Run twice: with the zenoh output's rate limit lifted (`meas_default_hz` 1e6: every
measurement published; the six draft marks share one topic, `meas/draft/can0.DraftMark`,
and arrive microseconds apart, so any finite limit would thin them), and with the
default limit (10 Hz per measurement topic).

With `--manoeuvre FILTER:WORKER[,...]` (e.g. `ukf:loop,ukf:process,enkf:loop`) it also
runs the default-limit case with a manoeuvre estimator of that filter in that worker
placement beside the inputs: a filter in the event loop delays the inputs' path by
its updates, one in a process of its own does not.

The script runs itself with `--subscriber` as the receiving process.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import socket
import subprocess
import sys
import threading
import time

VESSEL = "benchlat"
PREFIX = f"vessel/{VESSEL}"
MARKS = ("fore_port", "fore_stbd", "mid_port", "mid_stbd", "aft_port", "aft_stbd")


# -- subscriber process ----------------------------------------------------------------
def subscriber(listen: str) -> int:
    import zenoh

    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"peer"')
    cfg.insert_json5("listen/endpoints", json.dumps([listen]))
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("scouting/gossip/enabled", "false")
    s = zenoh.open(cfg)
    lat: list[float] = []
    now = time.time
    alive, gone = threading.Event(), threading.Event()
    last_rx = [time.monotonic()]

    def on_sample(sample: "zenoh.Sample") -> None:
        rx = now()
        lat.append(rx - json.loads(sample.payload.to_bytes())["t"])
        last_rx[0] = time.monotonic()

    def on_alive(sample: "zenoh.Sample") -> None:
        (alive if sample.kind == zenoh.SampleKind.PUT else gone).set()

    sub = s.declare_subscriber(f"{PREFIX}/meas/**", on_sample)
    live = s.liveliness().declare_subscriber(f"{PREFIX}/alive", on_alive, history=True)
    if not alive.wait(30):
        print(json.dumps({"error": "no liveliness"}), flush=True)
        return 1
    # A query answered by the publisher's queryable: it has seen our subscriber by now.
    for _ in s.get(f"{PREFIX}/**", timeout=10):
        pass
    print("ready", flush=True)
    gone.wait(3600)
    while time.monotonic() - last_rx[0] < 0.5:
        time.sleep(0.05)
    print(json.dumps(lat), flush=True)
    live.undeclare()
    sub.undeclare()
    s.close()
    return 0


# -- publishing side --------------------------------------------------------------------
def _port() -> int:
    with socket.socket() as so:
        so.bind(("127.0.0.1", 0))
        return so.getsockname()[1]


def tick_records(k: int, t: float) -> list:
    """The measurements of 10-ms tick `k` of the reference load, stamped `t`."""
    from edged.records import Measurement

    recs = [Measurement("draft", "can0.DraftMark", t, {"mark": m, "draft": 7.0 + 0.01 * i, "status": 0})
            for i, m in enumerate(MARKS)]
    if k % 2 == 0:
        recs.append(Measurement("accel_body", "can0.ImuAccel", t, {"ax": 0.01, "ay": -0.02, "az": 0.0}))
        recs.append(Measurement("yaw_rate", "can0.ImuRate", t, {"r": 0.001}))
    if k % 10 == 0:
        recs.append(Measurement("position", "gnss1", t, {"lat": 60.1, "lon": 24.9, "fix_quality": 1, "hdop": 0.9,
                                                          "sats": 9}))
        recs.append(Measurement("velocity_ground", "gnss1", t, {"sog": 6.1, "cog": 1.2}))
        recs.append(Measurement("heading", "gyro", t, {"heading": 1.21}))
        recs.append(Measurement("yaw_rate", "gyro", t, {"r": 0.0012}))
    if k % 100 == 0:
        recs.append(Measurement("water_speed", "log", t, {"stw_long": 6.0, "stw_trans": 0.1}))
    return recs


def _pct(xs: list[float], p: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(p / 100.0 * len(xs)))]


async def run_once(seconds: float, meas_hz: float | None, estimators: dict | None = None) -> tuple[int, list[float]]:
    from edged.clock import LiveClock
    from edged.config import parse_config
    from edged.registry import Registry
    from edged.runtime import Runtime

    own, peer = _port(), _port()
    sub = subprocess.Popen([sys.executable, __file__, "--subscriber", "--listen", f"tcp/127.0.0.1:{peer}"],
                           stdout=subprocess.PIPE, text=True)
    try:
        registry = Registry()
        out_cfg = {"type": "zenoh", "listen": [f"tcp/127.0.0.1:{own}"], "connect": [f"tcp/127.0.0.1:{peer}"]}
        if meas_hz is not None:
            out_cfg["meas_default_hz"] = meas_hz
        cfg = parse_config({"edged": {"vessel_id": VESSEL}, "estimators": estimators or {}, "outputs": {"zenoh": out_cfg}},
                           registry, file="<bench>")
        clock = LiveClock()
        rt = Runtime(cfg, registry, clock)
        await rt.start()
        assert sub.stdout is not None
        line = await asyncio.wait_for(asyncio.to_thread(sub.stdout.readline), 60)
        assert line.strip() == "ready", line
        publish = rt.router.publish
        loop = asyncio.get_running_loop()
        start = loop.time()
        sent = 0
        for k in range(int(seconds * 100)):
            delay = start + k * 0.01 - loop.time()
            if delay > 0:
                await asyncio.sleep(delay)
            for m in tick_records(k, 0.0):
                m.t = clock.now()  # the wall time at publish, for the subscriber
                publish(m)
                sent += 1
        await asyncio.sleep(0.2)  # let the output task take the last batch
        await rt.stop()
        lat = json.loads(await asyncio.wait_for(asyncio.to_thread(sub.stdout.readline), 60))
        sub.wait(30)
    finally:
        if sub.poll() is None:
            sub.kill()
    return sent, lat


def report(label: str, seconds: float, sent: int, lat_s: list[float]) -> None:
    lat = [x * 1e3 for x in lat_s]
    if not lat:
        print(f"{label}: {sent} published in {seconds:.0f} s, nothing received")
        return
    print(f"{label}: {sent} measurements offered ({sent / seconds:.0f}/s), {len(lat)} received "
          f"({len(lat) / seconds:.0f}/s); latency p50 {_pct(lat, 50):.3f} ms, p99 {_pct(lat, 99):.3f} ms, "
          f"max {max(lat):.3f} ms")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--subscriber", action="store_true")
    ap.add_argument("--listen")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--manoeuvre", default="", help="FILTER:WORKER[,...] also with a manoeuvre estimator")
    a = ap.parse_args()
    if a.subscriber:
        return subscriber(a.listen)
    for label, hz in (("every measurement (meas_default_hz 1e6)", 1e6),
                      ("default limit (10 Hz per topic)", None)):
        sent, lat = asyncio.run(run_once(a.seconds, hz))
        report(label, a.seconds, sent, lat)
    for spec in filter(None, a.manoeuvre.split(",")):
        filt, worker = spec.split(":")
        est = {"manoeuvre": {"type": "manoeuvre", "filter": filt, "worker": worker}}
        sent, lat = asyncio.run(run_once(a.seconds, None, est))
        report(f"default limit, manoeuvre {filt} in the {worker}", a.seconds, sent, lat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
