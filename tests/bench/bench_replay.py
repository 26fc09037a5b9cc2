"""Benchmark: `edged replay FILE --record OUT.mcap` end to end, in sentences per second.

    .venv/bin/python tests/bench/bench_replay.py [--sentences 200000] [--mode both|nozenoh|zenoh]
                                                 [--subprocess] [--keep DIR]

Writes a deterministic NMEA 0183 log (TAG-block timestamps, valid checksums): GGA, VTG,
HDT and RMC at 10 Hz, VBW and VHW at 1 Hz, a vessel steaming at ~12 kn on a slowly
changing course. Then runs the real command line on it (`edged.cli.main` in this
process, timed around the call; `--subprocess` times `python -m edged.cli` from outside,
interpreter start-up included):

(a) `edged replay LOG --record OUT.mcap --no-zenoh`
(b) `edged replay LOG --record OUT.mcap --zenoh-config Z.json5` with the safe defaults
    except the endpoints (listen on a free port the benchmark picks, connect to the
    subscriber's), and a live subscriber in another process on `vessel/<id>/**` that
    counts what it receives.

Target (b): >= 20,000 sentences/s with the subscriber (twice the 9-11k of the
open-source marine servers measured on these machines).

The script runs itself with `--subscriber` as the receiving process.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from functools import reduce
from operator import xor
from pathlib import Path

T0 = 1_732_350_000.0
VESSEL = "benchrp"
TARGET = 20_000.0


# -- the log ---------------------------------------------------------------------
def _cs(body: str) -> str:
    return "%02X" % reduce(xor, body.encode(), 0)


def _line(t: float, body: str) -> str:
    tag = f"c:{t:.3f}"
    return f"\\{tag}*{_cs(tag)}\\${body}*{_cs(body)}"


def _dm(deg: float, width: int) -> str:
    d = int(deg)
    return f"{d:0{width}d}{(deg - d) * 60:07.4f}"


def make_log(n_sentences: int) -> list[str]:
    """~n sentences: per second of data 10 x (GGA, VTG, HDT, RMC) + VBW + VHW = 42."""
    lines: list[str] = []
    lat, lon = 59.5, 20.0
    sog_kn = 12.0
    k = 0
    while len(lines) < n_sentences:
        t = T0 + k * 0.1
        tm = time.gmtime(t)
        hms = time.strftime("%H%M%S", tm) + f".{int(round((t % 1) * 100)) % 100:02d}"
        ddmmyy = time.strftime("%d%m%y", tm)
        cog = (45.0 + 20.0 * math.sin(k / 3000.0)) % 360.0
        hdg = (cog + 2.0 + 0.5 * math.sin(k / 37.0)) % 360.0
        sog = sog_kn + 0.3 * math.sin(k / 91.0)
        dist_nm = sog * 0.1 / 3600.0
        lat += dist_nm / 60.0 * math.cos(math.radians(cog))
        lon += dist_nm / 60.0 * math.sin(math.radians(cog)) / math.cos(math.radians(lat))
        la, lo = _dm(lat, 2), _dm(lon, 3)
        lines.append(_line(t, f"GPGGA,{hms},{la},N,{lo},E,1,11,0.8,12.3,M,18.9,M,,"))
        lines.append(_line(t, f"GPVTG,{cog:.1f},T,{cog - 6.0:.1f},M,{sog:.2f},N,{sog * 1.852:.2f},K,A"))
        lines.append(_line(t, f"HEHDT,{hdg:.2f},T"))
        lines.append(_line(t, f"GPRMC,{hms},A,{la},N,{lo},E,{sog:.2f},{cog:.1f},{ddmmyy},6.0,E,A"))
        if k % 10 == 0:
            stw = sog - 0.4
            lines.append(_line(t, f"VMVBW,{stw:.2f},0.05,A,{sog:.2f},0.10,A"))
            lines.append(_line(t, f"VMVHW,{hdg:.1f},T,{hdg - 6.0:.1f},M,{stw:.2f},N,{stw * 1.852:.2f},K"))
        k += 1
    return lines[:n_sentences]


# -- subscriber process ------------------------------------------------------------
def subscriber(listen: str, prefix: str) -> int:
    """Count every sample under `prefix/**` until the vessel's liveliness goes and the
    link has been quiet for a second; print the counts as JSON."""
    import zenoh

    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"peer"')
    cfg.insert_json5("listen/endpoints", json.dumps([listen]))
    cfg.insert_json5("scouting/multicast/enabled", "false")
    cfg.insert_json5("scouting/gossip/enabled", "false")
    s = zenoh.open(cfg)
    counts: dict[str, int] = {}
    last_health: list[bytes] = []
    gone = threading.Event()
    last_rx = [time.monotonic()]
    mono = time.monotonic

    def on_sample(sample: "zenoh.Sample") -> None:
        key = str(sample.key_expr)
        counts[key] = counts.get(key, 0) + 1
        last_rx[0] = mono()
        if key.endswith("/health"):
            last_health[:] = [sample.payload.to_bytes()]

    def on_alive(sample: "zenoh.Sample") -> None:
        if sample.kind == zenoh.SampleKind.DELETE:
            gone.set()

    sub = s.declare_subscriber(f"{prefix}/**", on_sample)
    live = s.liveliness().declare_subscriber(f"{prefix}/alive", on_alive)
    print("ready", flush=True)
    gone.wait(3600)
    while mono() - last_rx[0] < 1.0:  # the DELETE may overtake the last samples
        time.sleep(0.1)
    published = None
    if last_health:
        for c in json.loads(last_health[0]).get("outputs", {}).values():
            if c.get("type") == "zenoh":
                published = c.get("counters", {})
    print(json.dumps({"received": sum(counts.values()), "by_kind": _by_kind(counts, prefix),
                      "zenoh_counters": published}), flush=True)
    live.undeclare()
    sub.undeclare()
    s.close()
    return 0


def _by_kind(counts: dict[str, int], prefix: str) -> dict[str, int]:
    out: dict[str, int] = {}
    for key, n in counts.items():
        parts = key[len(prefix) + 1:].split("/")
        k = "/".join(parts[:2]) if parts[0] in ("meas", "est") else parts[0]
        out[k] = out.get(k, 0) + n
    return out


# -- running the replay ---------------------------------------------------------------
def _port() -> int:
    with socket.socket() as so:
        so.bind(("127.0.0.1", 0))
        return so.getsockname()[1]


def run_replay(argv: list[str], use_subprocess: bool) -> tuple[float, float, int, str]:
    """(wall seconds, CPU seconds of the replay process, exit code, its standard output).

    CPU time (all threads, zenoh's included) is steadier than wall time on a shared
    machine: when the two differ much, something else was using the cores.
    """
    if use_subprocess:
        before = os.times()
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "edged.cli", *argv], capture_output=True, text=True)
        wall = time.perf_counter() - t0
        after = os.times()
        cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
        return wall, cpu, p.returncode, p.stdout + p.stderr
    from edged.cli import main as cli_main

    buf = io.StringIO()
    c0 = time.process_time()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(buf):
        rc = cli_main(argv)
    return time.perf_counter() - t0, time.process_time() - c0, rc, buf.getvalue()


def _summary_lines(out: str) -> str:
    return "\n".join("    " + ln for ln in out.splitlines() if ln.startswith(("replayed", "output ")))


def bench_no_zenoh(log: Path, work: Path, n: int, use_subprocess: bool) -> float:
    out = work / "nozenoh.mcap"
    argv = ["replay", str(log), "--record", str(out), "--no-zenoh", "--no-progress"]
    wall, cpu, rc, text = run_replay(argv, use_subprocess)
    assert rc == 0, text
    rate = n / wall
    print(f"(a) --no-zenoh:            {wall:7.2f} s wall ({cpu:.2f} s CPU), {rate:10,.0f} sentences/s  "
          f"(mcap {out.stat().st_size / 1e6:.1f} MB)")
    print(_summary_lines(text))
    return rate


def bench_zenoh(log: Path, work: Path, n: int, use_subprocess: bool) -> float:
    own, peer = _port(), _port()
    zcfg = work / "bench.json5"
    # Listen on our own port (as the defaults would on 7447) and also connect to the
    # subscriber, so the link is up as soon as the replay's session opens.
    zcfg.write_text('{listen: {endpoints: ["tcp/127.0.0.1:%d"]}, connect: {endpoints: ["tcp/127.0.0.1:%d"]}}'
                    % (own, peer))
    sub = subprocess.Popen(
        [sys.executable, __file__, "--subscriber", "--listen", f"tcp/127.0.0.1:{peer}"],
        stdout=subprocess.PIPE, text=True,
    )
    try:
        assert sub.stdout is not None
        assert sub.stdout.readline().strip() == "ready"
        out = work / "zenoh.mcap"
        argv = ["replay", str(log), "--record", str(out), "--no-progress",
                "--vessel-id", VESSEL, "--zenoh-config", str(zcfg)]
        wall, cpu, rc, text = run_replay(argv, use_subprocess)
        assert rc == 0, text
        got = json.loads(sub.stdout.readline())
        sub.wait(30)
    finally:
        if sub.poll() is None:
            sub.kill()
    rate = n / wall
    print(f"(b) zenoh + subscriber:    {wall:7.2f} s wall ({cpu:.2f} s CPU), {rate:10,.0f} sentences/s  "
          f"(target >= {TARGET:,.0f}: {'OK' if rate >= TARGET else 'UNDER'})")
    print(_summary_lines(text))
    zc = got.get("zenoh_counters") or {}
    print(f"    subscriber received {got['received']} samples "
          f"(zenoh output at its last health: published {zc.get('published')}, "
          f"rate_limited {zc.get('rate_limited')}, unsent.no_session {zc.get('unsent.no_session', 0)}); "
          f"by kind {got['by_kind']}")
    return rate


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--subscriber", action="store_true")
    ap.add_argument("--listen")
    ap.add_argument("--sentences", type=int, default=200_000)
    ap.add_argument("--mode", choices=["both", "nozenoh", "zenoh"], default="both")
    ap.add_argument("--subprocess", action="store_true", help="time `python -m edged.cli` from outside")
    ap.add_argument("--keep", metavar="DIR", help="write the log and recordings here instead of a temp dir")
    a = ap.parse_args()
    if a.subscriber:
        return subscriber(a.listen, f"vessel/{VESSEL}")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(a.keep) if a.keep else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        log = work / "gnss.nmea"
        lines = make_log(a.sentences)
        log.write_text("\r\n".join(lines) + "\r\n")
        n = len(lines)
        print(f"log: {n} sentences (GGA/VTG/HDT/RMC 10 Hz, VBW/VHW 1 Hz), "
              f"{n / 42:.0f} s of data, {log.stat().st_size / 1e6:.1f} MB; "
              f"{'subprocess' if a.subprocess else 'in-process edged.cli.main'}")
        if a.mode in ("both", "nozenoh"):
            bench_no_zenoh(log, work, n, a.subprocess)
        if a.mode in ("both", "zenoh"):
            bench_zenoh(log, work, n, a.subprocess)
    return 0


if __name__ == "__main__":
    sys.exit(main())
