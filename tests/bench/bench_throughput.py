"""Benchmark of issue 34: edged beside the pynmea2 floor, in one run, start-up included.

    .venv/bin/python tests/bench/bench_throughput.py [--sentences 200000] [--runs 3]
                                                     [--plaka PATH] [--no-default]

Each row is the median of `--runs` runs, side by side in this order, so that the
machine's drift (twofold within an hour on the 2-vCPU machines) falls on all of them:
1. the floor: `pynmea2.parse(line)` of every line of the log, in one process, no output
   (what any Python NMEA 0183 reader pays);
2. `edged replay LOG --record OUT.mcap` with a live Zenoh subscriber in another process
   (`bench_replay.subscriber`), as a user runs it (`python -m edged.cli`, a process of
   its own: interpreter, imports, children and the end of the recording counted):
   - with no estimator (a configuration without `[estimators.*]`);
   - with the built-in default configuration (every installed estimator), unless
     `--no-default`;
3. start-up: from the command's start to its first record read (the replay's
   `event=replay-started` log line, at `--log-level info`, timed as it arrives), for a
   one-line log with Zenoh and recording.
The checkout's own modules are compiled to bytecode first, as an install has them (pip
compiles at install; a run with PYTHONDONTWRITEBYTECODE set, as some sandboxes are,
would otherwise compile ~100 modules at every start, 80 ms).
Logs: the synthetic mix of `bench_replay.make_log` (GGA/VTG/HDT/RMC at 10 Hz, VBW/VHW
at 1 Hz) and Signal K's real `plaka.log` (`--plaka`; from ../shared/data).
Targets (issue 34): default ≥ 0.15× the floor on the mix; no estimator ≥ 0.24× on the
mix and ≥ 0.46× on plaka.log; start-up ≤ 0.2 s. The 1-hour reference voyage is
`bench_e2e.py`'s. Not a pytest test (no `test_` prefix): run it on demand.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_replay import VESSEL, _port, make_log  # noqa: E402  (this folder)

HERE = Path(__file__).resolve().parent
PLAKA = HERE.parents[2] / "shared" / "data" / "nmea0183" / "signalk-server__samples__plaka.log"
NO_ESTIMATOR = '[edged]\nvessel_id = "%s"\n' % VESSEL
TARGETS = {("mix", "no estimator"): 0.24, ("plaka", "no estimator"): 0.46, ("mix", "default"): 0.15}


def floor(log: Path) -> float:
    """Lines per second of bare `pynmea2.parse(sentence, check=True)` over the log
    (DEPENDENCIES.md's floor). pynmea2 does not read TAG blocks: the sentence after one
    is parsed, outside the timing. A line it refuses raises and the loop goes on."""
    import pynmea2

    lines = [ln.rsplit("\\", 1)[-1] if ln.startswith("\\") else ln
             for ln in log.read_text(errors="replace").splitlines()]
    parse = pynmea2.parse
    t0 = time.perf_counter()
    for ln in lines:
        try:
            parse(ln, check=True)
        except Exception:
            pass
    return len(lines) / (time.perf_counter() - t0)


def _zenoh_pair(work: Path, peer: bool = True) -> tuple[Path, str]:
    """A zenoh configuration listening on a free port and, with `peer`, connecting to
    the subscriber's (so the link is up as the replay's session opens)."""
    own, other = _port(), _port()
    z = work / f"z{own}.json5"
    connect = ', connect: {endpoints: ["tcp/127.0.0.1:%d"]}' % other if peer else ""
    z.write_text('{listen: {endpoints: ["tcp/127.0.0.1:%d"]}%s}' % (own, connect))
    return z, f"tcp/127.0.0.1:{other}"


def edged(log: Path, work: Path, config: Path | None) -> tuple[float, dict]:
    """(wall seconds of `edged replay` as a process, what the subscriber received)."""
    zcfg, listen = _zenoh_pair(work)
    sub = subprocess.Popen([sys.executable, str(HERE / "bench_replay.py"), "--subscriber", "--listen", listen],
                           stdout=subprocess.PIPE, text=True)
    try:
        assert sub.stdout is not None and sub.stdout.readline().strip() == "ready"
        argv = [sys.executable, "-m", "edged.cli", "replay", str(log), "--record", str(work / "out.mcap"),
                "--no-progress", "--vessel-id", VESSEL, "--zenoh-config", str(zcfg)]
        if config is not None:
            argv += ["-c", str(config)]
        t0 = time.perf_counter()
        p = subprocess.run(argv, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            raise SystemExit(f"edged replay failed ({p.returncode}):\n{p.stdout[-2000:]}{p.stderr[-2000:]}")
        got = json.loads(sub.stdout.readline())
        sub.wait(30)
    finally:
        if sub.poll() is None:
            sub.kill()
    return wall, got


def startup(work: Path, line: str) -> float:
    """Seconds from the command's start to its first record read (Zenoh and recording
    on, the default configuration)."""
    log = work / "one.nmea"
    log.write_text(line + "\n")
    zcfg, _ = _zenoh_pair(work, peer=False)
    argv = [sys.executable, "-m", "edged.cli", "--log-level", "info", "replay", str(log), "--record",
            str(work / "one.mcap"), "--no-progress", "--vessel-id", VESSEL, "--zenoh-config", str(zcfg)]
    t0 = time.perf_counter()
    p = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    first = None
    assert p.stderr is not None
    for ln in p.stderr:
        if first is None and "event=replay-started" in ln:
            first = time.perf_counter() - t0
    p.wait(120)
    if first is None:
        raise SystemExit("edged replay said no event=replay-started (its log level?)")
    return first


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sentences", type=int, default=200_000)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--plaka", type=Path, default=PLAKA)
    ap.add_argument("--no-default", action="store_true", help="leave out the default configuration's rows")
    args = ap.parse_args()
    root = HERE.parents[1]
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(root / "edged"), str(root / "plugins")],
                   check=True, stdout=subprocess.DEVNULL)
    with tempfile.TemporaryDirectory() as d:
        work = Path(d)
        mix = work / "mix.nmea"
        mix.write_text("\n".join(make_log(args.sentences)) + "\n")
        logs = {"mix": mix}
        if args.plaka.is_file():
            logs["plaka"] = args.plaka
        else:
            print(f"({args.plaka} not found: plaka.log rows left out)")
        none = work / "none.toml"
        none.write_text(NO_ESTIMATOR)
        configs: dict[str, Path | None] = {"no estimator": none}
        if not args.no_default:
            configs["default"] = None
        rows: dict[tuple[str, str], list[float]] = {}
        for _ in range(args.runs):
            for name, log in logs.items():
                n = sum(1 for _ in open(log, "rb"))
                rows.setdefault((name, "floor"), []).append(floor(log))
                for cname, cfg in configs.items():
                    wall, got = edged(log, work, cfg)
                    rows.setdefault((name, cname), []).append(n / wall)
                    print(f"  {name:5} {cname:12} {n / wall:9,.0f} lines/s  ({wall:.2f} s; subscriber got {got['received']})",
                          flush=True)
            rows.setdefault(("one line", "start-up"), []).append(startup(work, mix.read_text().splitlines()[0]))
        print("\n| log | run | lines/s (median) | × floor | target |\n|---|---|---|---|---|")
        for (name, what), vals in rows.items():
            if what in ("floor", "start-up"):
                continue
            med, fl = statistics.median(vals), statistics.median(rows[(name, "floor")])
            target = TARGETS.get((name, what))
            verdict = "" if target is None else f"≥ {target}×: {'met' if med / fl >= target else 'not met'}"
            print(f"| {name} | {what} | {med:,.0f} | {med / fl:.3f} | {verdict} |")
        for name in logs:
            print(f"| {name} | pynmea2 floor | {statistics.median(rows[(name, 'floor')]):,.0f} | 1 | |")
        s = statistics.median(rows[("one line", "start-up")])
        print(f"\nstart-up to the first record (default configuration, Zenoh, recording): {s:.2f} s "
              f"(target ≤ 0.2 s: {'met' if s <= 0.2 else 'not met'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
