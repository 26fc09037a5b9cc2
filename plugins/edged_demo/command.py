"""The `edged demo` command: one pipeline, the simulated vessel feeding it."""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import shlex
import socket
import sys
import time
from pathlib import Path
from typing import Any, Awaitable, Callable, TextIO

from edged.clock import LiveClock
from edged.runcmd import run_daemon
from edged.config import ConfigError, parse_config
from edged.logs import setup_logging
from edged.registry import Registry
from edged.runtime import Runtime
from edged.subcommand import Subcommand, positive_seconds, zenoh_options

from .truth import OriginClock, TruthWriter

log = logging.getLogger("edged.demo")

SCENARIO = "demo"
SEED = 0
#: Seconds between the plain status lines printed without a terminal.
STATUS_EVERY_S = 5.0
#: Seconds between the truth file's updates (each simulates that much again).
TRUTH_EVERY_S = 1.0
#: `edged score`'s default --warmup: a shorter demo is scored after a third of it.
DEFAULT_WARMUP_S = 60.0


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def demo_config(
    registry: Registry, record_dir: Path, udp_port: int, can_channel: str, *, zenoh: bool, vessel_id: str,
    foxglove_port: int = 0,
) -> dict[str, Any]:
    """The demo's configuration: every installed estimator, the two inputs, the outputs
    (a live Foxglove view on 127.0.0.1 when `foxglove_port` is given and installed)."""
    outputs: dict[str, Any] = {"recorder": {"type": "mcap", "directory": str(record_dir)}}
    if zenoh:
        outputs["zenoh"] = {"type": "zenoh"}
    if foxglove_port and "foxglove" in registry.names("outputs"):
        outputs["foxglove"] = {"type": "foxglove", "host": "127.0.0.1", "port": foxglove_port}
    return {
        "edged": {"vessel_id": vessel_id},
        "inputs": {
            "nmea": {"type": "nmea0183", "transport": "udp", "port": udp_port, "bind": "127.0.0.1"},
            "can0": {"type": "can", "interface": "virtual", "channel": can_channel},
        },
        "estimators": {name: {"type": name} for name in registry.names("estimators")},
        "outputs": outputs,
    }


def _foxglove_line(cfg: Any) -> str:
    fox = cfg.outputs.get("foxglove")
    if fox is None:
        return "off"
    return (f"ws://127.0.0.1:{fox.port} live (a layout for the demo's sources: "
            "python -m edged_foxglove.layout --gnss nmea --log nmea > demo-layout.json)")


def _status_line(rt: Runtime) -> str:
    meas = sum(
        v for h in rt.health.components.values() if h.role == "input"
        for k, v in h.counters.items() if k.startswith("measurements.")
    )
    est = sum(w.health.counters.get("estimates", 0) for w in rt.workers)
    outs = ", ".join(f"{o.name} {o.health.state} {o.health.counters.get('written', 0)}" for o in rt.outputs)
    return f"demo: {meas} measurements, {est} estimates; outputs: {outs}"


def _isatty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


async def _plain_report(rt: Runtime, out: TextIO) -> None:
    """Without a terminal (CI, a pipe, a log file): one status line every few seconds."""
    while True:
        await asyncio.sleep(STATUS_EVERY_S)
        print(_status_line(rt), file=out, flush=True)


async def _demo(
    rt: Runtime, vessel: Any, udp_port: int, channel: str, duration: float | None, out: TextIO,
    *, reporter: Callable[[], Awaitable[None]] | None = None, truth: TruthWriter | None = None,
) -> int:
    """Run the daemon and the vessel until the duration, a signal or the vessel's end.
    `reporter`: what shows the demo's progress (the dashboard on a terminal; plain
    status lines by default); `truth`: kept up to date while the vessel plays and
    finished when it stops."""
    stop = asyncio.Event()

    async def play() -> None:
        try:
            await vessel.run(can_channel=channel, nmea_udp_port=udp_port)
        except Exception as exc:  # the demo must say why it stopped
            log.error("event=simulator-failed error=%r", f"{type(exc).__name__}: {exc}")
        finally:
            stop.set()

    async def keep_truth() -> None:
        while truth is not None:
            await asyncio.sleep(TRUTH_EVERY_S)
            if not _truth_step(truth.advance, rt.clock.now()):
                return

    # The daemon starts first so that its inputs listen before the vessel speaks.
    daemon = asyncio.ensure_future(run_daemon(rt, stop, duration))
    while not all(o.opened for o in rt.outputs) and not daemon.done():
        await asyncio.sleep(0.01)
    player = asyncio.ensure_future(play())
    tasks = [player, asyncio.ensure_future((reporter or (lambda: _plain_report(rt, out)))())]
    if truth is not None:
        tasks.append(asyncio.ensure_future(keep_truth()))
    try:
        return await daemon
    finally:
        for t in tasks:
            t.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        if truth is not None:
            _truth_step(truth.finish, rt.clock.now())
        print(_status_line(rt), file=out, flush=True)


def _as_run(argv0: str | None = None) -> str:
    """How the user ran edged, to print commands they can paste: the script's path
    (`.venv/bin/edged`), `python -m edged.cli` (argv[0] is then cli.py), or `edged`."""
    argv0 = sys.argv[0] if argv0 is None else argv0
    if argv0.endswith(".py"):
        return f"{shlex.quote(sys.executable)} -m edged.cli"
    return shlex.quote(argv0) if os.sep in argv0 else "edged"


def _truth_step(step: Callable[[float], Any], t: float) -> bool:
    """A truth file that cannot be written is said once and given up, never the demo."""
    try:
        step(t)
        return True
    except Exception as exc:
        log.warning("event=truth-not-written error=%r", f"{type(exc).__name__}: {exc}")
        return False


def main(args: argparse.Namespace, registry: Registry | None = None, out: TextIO = sys.stdout) -> int:
    registry = registry or Registry()
    try:
        from edged_sim.live import LiveVessel
    except ImportError as exc:
        print(f"edged demo: the simulator is not installed ({exc})", file=sys.stderr)
        return 1
    clock = LiveClock()
    stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime(clock.now()))
    record_dir = Path(args.record_dir or f"edged-demo-{stamp}").resolve()
    record_dir.mkdir(parents=True, exist_ok=True)
    before = set(record_dir.glob("*.mcap"))
    udp_port = free_udp_port()
    channel = f"edged-demo-{os.getpid()}"
    data = demo_config(
        registry, record_dir, udp_port, channel, zenoh=not args.no_zenoh, vessel_id=args.vessel_id or "demo",
        foxglove_port=args.foxglove_port,
    )
    try:
        cfg = parse_config(data, registry, file="<demo>")
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return 1
    setup_logging(args.log_level or "warning")
    options: dict[str, Any] = {}
    if args.zenoh_config:
        options["zenoh_config"] = str(Path(args.zenoh_config).resolve())
    rt = Runtime(cfg, registry, clock, options=options)
    estimators = ", ".join(w.name for w in rt.workers) or "none installed yet: inputs -> router -> outputs only"
    reporter = _dashboard(rt, out, clock, cfg.edged.vessel_id)
    print(
        f"edged demo: simulated vessel '{SCENARIO}' -> NMEA 0183 over UDP 127.0.0.1:{udp_port} "
        f"and NMEA 2000/DBC frames on virtual CAN '{channel}'\n"
        f"  estimators: {estimators}\n"
        f"  recording:  {record_dir}\n"
        f"  zenoh:      {'off' if args.no_zenoh else f'vessel/{cfg.edged.vessel_id}/** on this machine only'}\n"
        f"  foxglove:   {_foxglove_line(cfg)}\n"
        f"  {'stops after ' + format(args.duration, 'g') + ' s' if args.duration else 'Ctrl-C stops it'}",
        file=out,
        flush=True,
    )
    origin = OriginClock(clock)
    vessel = LiveVessel(SCENARIO, seed=SEED, clock=origin)
    truth: TruthWriter | None = None
    try:
        truth = TruthWriter(record_dir / f"truth-{stamp}.csv", SCENARIO, SEED, origin)
    except Exception as exc:  # the demo runs without it
        log.warning("event=truth-not-written error=%r", f"{type(exc).__name__}: {exc}")
    rc = asyncio.run(_demo(rt, vessel, udp_port, channel, args.duration, out, reporter=reporter, truth=truth))
    files = sorted(set(record_dir.glob("*.mcap")) - before)
    if truth is not None and truth.rows and files:
        try:  # named after the recording it goes with: edged-<start>.truth.csv
            truth.rename(files[0].with_name(files[0].stem + ".truth.csv"))
        except OSError as exc:
            log.warning("event=truth-not-renamed path=%s error=%r", truth.path, str(exc))
    _say_where(out, files, truth)
    return rc


def _dashboard(rt: Runtime, out: TextIO, clock: LiveClock, vessel_id: str) -> Callable[[], Awaitable[None]] | None:
    """The live dashboard when `out` is a terminal (None otherwise: plain lines). It
    subscribes to the router now, before anything is published."""
    if not _isatty(out):
        return None
    from rich.console import Console

    console = Console(file=out)
    if not console.is_terminal or console.is_dumb_terminal:
        return None
    from .feed import LatestFeed
    from .live import run_dashboard

    feed = LatestFeed(rt.router, [w.name for w in rt.workers])
    extra = {"vessel_id": vessel_id, "started": clock.now()}
    return lambda: run_dashboard(feed, console, clock.now, extra)


def _say_where(out: TextIO, files: list[Path], truth: TruthWriter | None) -> None:
    """Where the recording and its truth are, and the commands that look at them."""
    print(f"edged demo: recorded {', '.join(str(f) for f in files) or 'nothing'}", file=out)
    truth_file = truth.path if truth is not None and truth.rows else None
    if truth is not None and truth_file is not None:
        print(f"  truth:       {truth_file} (the simulated vessel's true state, {truth.rows} rows)", file=out)
    if not files:
        return
    edged = _as_run()
    f = shlex.quote(str(files[-1]))
    print(f"  look at it:  {edged} inspect {f}", file=out)
    if truth is None or truth_file is None:
        print(f"  plot it:     {edged} plot {f} -o demo.png", file=out)
        return
    t = shlex.quote(str(truth_file))
    warmup = "" if truth.played >= 3 * DEFAULT_WARMUP_S else f" --warmup {truth.played // 3:g}"
    print(f"  score it:    {edged} score {f} --truth {t}{warmup}", file=out)
    print(f"  plot it:     {edged} plot {f} --truth {t} -o demo.png", file=out)


def arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--duration", type=positive_seconds, default=None, metavar="S", help="stop after S seconds (default: until Ctrl-C)")
    p.add_argument("--record-dir", metavar="DIR", help="where to record (default ./edged-demo-<UTC start>/)")
    p.add_argument("--no-zenoh", action="store_true", help="do not publish over zenoh")
    p.add_argument("--foxglove-port", type=int, default=8765, metavar="PORT",
                   help="serve a live Foxglove view on 127.0.0.1:PORT (default 8765; 0: off)")
    zenoh_options(p)


#: `edged demo` (entry point `edged.commands: demo`).
COMMAND = Subcommand("run the built-in simulated vessel end to end", arguments, main)
