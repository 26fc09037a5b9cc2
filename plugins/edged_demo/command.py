"""The `edged demo` command: one pipeline, the simulated vessel feeding it."""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import socket
import sys
import time
from pathlib import Path
from typing import Any, TextIO

from edged.clock import LiveClock
from edged.commands import run_daemon
from edged.config import ConfigError, parse_config
from edged.logs import setup_logging
from edged.registry import Registry
from edged.runtime import Runtime

log = logging.getLogger("edged.demo")

SCENARIO = "demo"
STATUS_EVERY_S = 5.0


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def demo_config(
    registry: Registry, record_dir: Path, udp_port: int, can_channel: str, *, zenoh: bool, vessel_id: str
) -> dict[str, Any]:
    """The demo's configuration: every installed estimator, the two inputs, the outputs."""
    outputs: dict[str, Any] = {"recorder": {"type": "mcap", "directory": str(record_dir)}}
    if zenoh:
        outputs["zenoh"] = {"type": "zenoh"}
    return {
        "edged": {"vessel_id": vessel_id},
        "inputs": {
            "nmea": {"type": "nmea0183", "transport": "udp", "port": udp_port, "bind": "127.0.0.1"},
            "can0": {"type": "can", "interface": "virtual", "channel": can_channel},
        },
        "estimators": {name: {"type": name} for name in registry.names("estimators")},
        "outputs": outputs,
    }


def _status_line(rt: Runtime) -> str:
    meas = sum(
        v for h in rt.health.components.values() if h.role == "input"
        for k, v in h.counters.items() if k.startswith("measurements.")
    )
    est = sum(w.health.counters.get("estimates", 0) for w in rt.workers)
    outs = ", ".join(f"{o.name} {o.health.state} {o.health.counters.get('written', 0)}" for o in rt.outputs)
    return f"demo: {meas} measurements, {est} estimates; outputs: {outs}"


async def _demo(rt: Runtime, vessel: Any, udp_port: int, channel: str, duration: float | None, out: TextIO) -> int:
    stop = asyncio.Event()

    async def play() -> None:
        try:
            await vessel.run(can_channel=channel, nmea_udp_port=udp_port)
        except Exception as exc:  # the demo must say why it stopped
            log.error("event=simulator-failed error=%r", f"{type(exc).__name__}: {exc}")
        finally:
            stop.set()

    async def report() -> None:
        while True:
            await asyncio.sleep(STATUS_EVERY_S)
            print(_status_line(rt), file=out, flush=True)

    # The daemon starts first so that its inputs listen before the vessel speaks.
    daemon = asyncio.ensure_future(run_daemon(rt, stop, duration))
    while not all(o.opened for o in rt.outputs) and not daemon.done():
        await asyncio.sleep(0.01)
    player = asyncio.ensure_future(play())
    reporter = asyncio.ensure_future(report())
    try:
        return await daemon
    finally:
        for t in (player, reporter):
            t.cancel()
        await asyncio.gather(player, reporter, return_exceptions=True)
        print(_status_line(rt), file=out, flush=True)


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
    udp_port = free_udp_port()
    channel = f"edged-demo-{os.getpid()}"
    data = demo_config(
        registry, record_dir, udp_port, channel, zenoh=not args.no_zenoh, vessel_id=args.vessel_id or "demo"
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
    print(
        f"edged demo: simulated vessel '{SCENARIO}' -> NMEA 0183 over UDP 127.0.0.1:{udp_port} "
        f"and NMEA 2000/DBC frames on virtual CAN '{channel}'\n"
        f"  estimators: {estimators}\n"
        f"  recording:  {record_dir}\n"
        f"  zenoh:      {'off' if args.no_zenoh else f'vessel/{cfg.edged.vessel_id}/** on this machine only'}\n"
        f"  {'stops after ' + format(args.duration, 'g') + ' s' if args.duration else 'Ctrl-C stops it'}",
        file=out,
        flush=True,
    )
    vessel = LiveVessel(SCENARIO, seed=0, clock=clock)
    rc = asyncio.run(_demo(rt, vessel, udp_port, channel, args.duration, out))
    files = sorted(record_dir.glob("*.mcap"))
    print(f"edged demo: recorded {', '.join(str(f) for f in files) or 'nothing'}", file=out)
    if files:
        edged = sys.argv[0] if os.sep in sys.argv[0] else "edged"  # as the user ran it
        print(f"  look at it:  {edged} inspect {files[-1]}", file=out)
        print(f"               {edged} plot {files[-1]} -o demo.png", file=out)
    return rc
