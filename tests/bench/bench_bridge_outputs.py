"""Benchmark: what the four bridge outputs cost at the reference load (issue 35).

    .venv/bin/python tests/bench/bench_bridge_outputs.py [--duration 600] [--seed 1]
                                                         [--runs 3] [--work DIR]

1. The records: `edged sim demo` (DESIGN §9's reference load) for `--duration` s of
   data, replayed with the three estimators and `--record` (cached in `--work`); the
   recording's estimates and measurements are read back into records, in file order:
   exactly what the router hands an output in that voyage.
2. Each output (`nmea0183` over UDP, `nmea2000` on a python-can `virtual` bus,
   `signalk` as a TCP server, `foxglove` as its WebSocket server), and all four
   together, is made from its configuration table through the registry, opened, and
   given the records in batches of 64 (the output host's way), the event loop
   turning between batches so that its sockets are written. A consumer in another
   process reads everything sent (a UDP socket, a TCP client, a Foxglove WebSocket
   client subscribed to every channel), so the sockets are not idle. Measured: CPU
   time of this process (every thread: the Foxglove SDK's included) over the feed,
   less the same feed with no output, best of `--runs`; the share of one core is
   that CPU time over the data's duration. Target: all four under 1 %.

Not a pytest test (no `test_` prefix): run it on demand.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
sys.path.insert(0, str(HERE.parent / "support"))
sys.path.insert(0, str(HERE))

from bench_e2e import EDGED, ensure_sim, estimators_toml, particulars  # noqa: E402
from harness import recordings  # noqa: E402

BATCH = 64


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def recorded_voyage(work: Path, duration: float, seed: int) -> Path:
    """The reference voyage replayed with the three estimators, recorded (cached)."""
    sim, _, meta = ensure_sim(work, "demo", duration, seed)
    out = work / f"voyage-{duration:g}-{seed}.mcap"
    if out.exists():
        return out
    cfg = work / "estimators.toml"
    cfg.write_text(estimators_toml(particulars(meta)))
    p = subprocess.run([*EDGED, "replay", "-c", str(cfg), "--no-zenoh", "--no-progress", "--record", str(out),
                        str(sim / "nmea.log"), str(sim / "can.log")], capture_output=True, text=True, cwd=REPO)
    if p.returncode != 0:
        raise RuntimeError(f"edged replay failed ({p.returncode}): {p.stderr[-800:]}")
    return out


def voyage_records(path: Path) -> list[Any]:
    """The recording's estimates and measurements as the router carried them."""
    from edged.records import Estimate, Measurement
    from edged_mcap.reading import ReadReport, iter_messages

    records: list[Any] = []
    for p in recordings(path):
        with p.open("rb") as f:
            for ch, _, msg in iter_messages(f, ReadReport()):
                top = ch.topic.split("/")
                if ch.topic.startswith("/est/"):
                    d = json.loads(msg.data)
                    t, kind = d.pop("t"), d.pop("kind")
                    records.append(Estimate(top[2], top[2], t, d, kind))
                elif ch.topic.startswith("/meas/"):
                    d = json.loads(msg.data)
                    t = d.pop("t")
                    t_src = d.pop("t_src", None)
                    d.pop("kind", None), d.pop("source", None)
                    records.append(Measurement(top[2], top[3], t, d, t_src))
    return records


def output_tables(ports: dict[str, int]) -> dict[str, dict[str, Any]]:
    """Each output's configuration table, sending to the consumer's ports."""
    return {
        "nmea0183": {"type": "nmea0183", "transport": "udp", "port": ports["udp"]},
        "nmea2000": {"type": "nmea2000", "transport": "can", "interface": "virtual", "channel": "bench"},
        "signalk": {"type": "signalk", "transport": "tcp", "port": ports["signalk"]},
        "foxglove": {"type": "foxglove", "port": ports["foxglove"]},
    }


def make_outputs(names: list[str], tables: dict[str, dict[str, Any]], clock: Any) -> list[Any]:
    from edged.health import ComponentHealth
    from edged.plugin import PluginContext
    from edged.registry import Registry

    reg = Registry()
    outs = []
    for n in names:
        cls = reg.get("outputs", tables[n]["type"])
        cfg = cls.Config(**tables[n])
        ctx = PluginContext(name=n, clock=clock, health=ComponentHealth(n, "output", n, clock), publish=lambda r: None)
        out = cls(cfg, ctx)
        out.check()
        outs.append(out)
    return outs


async def feed(records: list[Any], outputs: list[Any], clock: Any, settle: float) -> float:
    """CPU seconds of this process over the feed of `records` to `outputs`."""
    for o in outputs:
        await o.open()
    await asyncio.sleep(settle)  # links up, the consumer connected
    cpu0 = time.process_time()
    for i in range(0, len(records), BATCH):
        batch = records[i:i + BATCH]
        clock.set(batch[-1].t)
        for o in outputs:
            o.write(batch)
        await asyncio.sleep(0)
    for o in outputs:
        o.flush()
    await asyncio.sleep(0.2)  # what is queued goes out (its CPU counted)
    cpu = time.process_time() - cpu0
    for o in outputs:
        await o.close()
    return cpu


async def consume(ports: dict[str, int], ready: Path) -> None:
    """(the consumer process) Read everything the outputs send, until killed."""
    import websockets

    loop = asyncio.get_running_loop()
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind(("127.0.0.1", ports["udp"]))
    udp.setblocking(False)

    async def drain_udp() -> None:
        while True:
            await loop.sock_recv(udp, 65536)

    async def drain_tcp() -> None:
        while True:
            try:
                r, _ = await asyncio.open_connection("127.0.0.1", ports["signalk"])
            except OSError:
                await asyncio.sleep(0.05)
                continue
            while await r.read(65536):
                pass

    async def drain_ws() -> None:
        while True:
            try:
                ws = await websockets.connect(f"ws://127.0.0.1:{ports['foxglove']}", max_size=None,
                                              subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"])
            except (OSError, websockets.exceptions.WebSocketException):
                await asyncio.sleep(0.05)
                continue
            n = 0
            try:
                async for m in ws:
                    if isinstance(m, str):
                        d = json.loads(m)
                        if d.get("op") == "advertise":
                            subs = [{"id": (n := n + 1), "channelId": c["id"]} for c in d["channels"]]
                            await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
            except websockets.exceptions.WebSocketException:
                pass

    async def drain_tcp_forever() -> None:
        while True:
            try:
                await drain_tcp()
            except OSError:
                await asyncio.sleep(0.05)

    ready.write_text("ready\n")
    await asyncio.gather(drain_udp(), drain_tcp_forever(), drain_ws())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "edged-bench-bridge")
    ap.add_argument("--outputs", default="nmea0183,nmea2000,signalk,foxglove", help="comma-separated")
    ap.add_argument("--role", choices=["bench", "consumer"], default="bench")
    ap.add_argument("--ports", default="")
    ap.add_argument("--ready", type=Path)
    a = ap.parse_args()
    if a.role == "consumer":
        asyncio.run(consume(json.loads(a.ports), a.ready))
        return 0
    a.work.mkdir(parents=True, exist_ok=True)
    records = voyage_records(recorded_voyage(a.work, a.duration, a.seed))
    span = records[-1].t - records[0].t
    n_est = sum(1 for r in records if type(r).__name__ == "Estimate")
    print(f"voyage: {span:.0f} s of data, {len(records)} records ({n_est} estimates)")
    ports = {"udp": free_port(socket.SOCK_DGRAM), "signalk": free_port(), "foxglove": free_port()}
    ready = a.work / "consumer.ready"
    ready.unlink(missing_ok=True)
    consumer = subprocess.Popen([sys.executable, __file__, "--role", "consumer", "--ports", json.dumps(ports),
                                 "--ready", str(ready)])
    try:
        while not ready.exists():
            time.sleep(0.05)
        tables = {n: t for n, t in output_tables(ports).items() if n in a.outputs.split(",")}
        cases = [[n] for n in tables] + ([list(tables)] if len(tables) > 1 else [])
        rows = []
        from edged.clock import ManualClock

        def best(names: list[str]) -> float:
            runs = []
            for _ in range(a.runs):
                clock = ManualClock(records[0].t)
                outs = make_outputs(names, tables, clock)
                runs.append(asyncio.run(feed(records, outs, clock, settle=0.5 if names else 0.0)))
            return min(runs)

        base = best([])
        print(f"feed without outputs: {base:.3f} CPU s")
        for names in cases:
            cpu = max(0.0, best(names) - base)
            rows.append(("+".join(names) if len(names) < 4 else "all four together", cpu, 100.0 * cpu / span))
        print("| outputs | CPU s | share of one core |\n|---|---|---|")
        for name, cpu, pct in rows:
            print(f"| {name} | {cpu:.3f} | {pct:.3f} % |")
    finally:
        consumer.kill()
        consumer.wait()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
