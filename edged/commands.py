"""The core's subcommands (`run`, `replay`, `check-config`) and dispatch to plugins'."""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
import sys
from pathlib import Path
from typing import Any, Callable, TextIO

from .clock import LiveClock, ReplayClock
from .cli import EXIT_FAILURE, EXIT_OK, EXIT_USAGE
from .config import Config, ConfigError, default_config, load_config
from .logs import reopen_logs, setup_logging
from .registry import PluginNotFound, Registry
from .replay import Replayer, ReplayStats, UnknownFormat
from .runtime import PluginBuildError, Runtime

log = logging.getLogger("edged")

#: Output plugin types the replay flags `--record` and `--no-zenoh` refer to (DESIGN §4).
RECORDER_TYPE = "mcap"
PUBLISHER_TYPE = "zenoh"


def dispatch(args: argparse.Namespace, registry: Registry | None = None) -> int:
    registry = registry or Registry()
    core: dict[str, Callable[[argparse.Namespace, Registry], int]] = {
        "run": cmd_run,
        "replay": cmd_replay,
        "check-config": cmd_check_config,
    }
    fn = core.get(args.command)
    if fn is not None:
        return fn(args, registry)
    try:
        plugin_cmd = registry.get("commands", args.command)
    except PluginNotFound:
        print(
            f"edged {args.command}: not available in this installation "
            f"(no plugin provides the command; entry point group edged.commands)",
            file=sys.stderr,
        )
        return EXIT_FAILURE
    setup_logging(args.log_level or "info")
    return int(plugin_cmd(args))


def _load(path: str | None, registry: Registry) -> Config:
    return load_config(path, registry) if path else default_config(registry)


def _with_overrides(cfg: Config, args: argparse.Namespace) -> Config:
    if getattr(args, "vessel_id", None):
        try:
            cfg.edged = cfg.edged.model_validate({**cfg.edged.model_dump(), "vessel_id": args.vessel_id})
        except Exception as exc:
            raise ConfigError("--vessel-id", [("vessel_id", str(exc).splitlines()[-1].strip())]) from None
    return cfg


def _options(args: argparse.Namespace) -> dict[str, Any]:
    opts: dict[str, Any] = {}
    zc = getattr(args, "zenoh_config", None)
    if zc:
        p = Path(zc)
        if not p.is_file():
            raise ConfigError(str(p), [("--zenoh-config", "no such file")])
        opts["zenoh_config"] = str(p.resolve())
    return opts


def cmd_check_config(args: argparse.Namespace, registry: Registry) -> int:
    try:
        cfg = load_config(args.config, registry)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    parts = [f"{len(getattr(cfg, r))} {r} ({', '.join(getattr(cfg, r)) or '-'})" for r in ("inputs", "estimators", "outputs")]
    print(f"{args.config}: OK: vessel {cfg.edged.vessel_id}; " + "; ".join(parts))
    return EXIT_OK


# -- run ------------------------------------------------------------------------
async def run_daemon(rt: Runtime, stop: asyncio.Event | None = None, duration: float | None = None) -> int:
    """Run until SIGTERM/SIGINT (or `stop`, or `duration` seconds); SIGHUP rotates."""
    loop = asyncio.get_running_loop()
    stop = stop or asyncio.Event()
    installed: list[int] = []

    def _hup() -> None:
        log.info("event=sighup action=reopen-logs,rotate")
        reopen_logs()
        rt.rotate()

    for sig, handler in ((signal.SIGTERM, stop.set), (signal.SIGINT, stop.set), (signal.SIGHUP, _hup)):
        try:
            loop.add_signal_handler(sig, handler)
            installed.append(sig)
        except (NotImplementedError, RuntimeError, ValueError):  # not the main thread
            pass
    try:
        await rt.start()
        log.info(
            "event=started vessel=%s inputs=%d estimators=%d outputs=%d",
            rt.config.edged.vessel_id,
            len(rt.inputs),
            len(rt.workers),
            len(rt.outputs),
        )
        if duration is None:
            await stop.wait()
        else:
            try:
                await asyncio.wait_for(stop.wait(), duration)
            except asyncio.TimeoutError:
                pass
        log.info("event=stopping")
    finally:
        await rt.stop()
        for sig in installed:
            loop.remove_signal_handler(sig)
    log.info("event=stopped")
    return EXIT_OK


def cmd_run(args: argparse.Namespace, registry: Registry) -> int:
    try:
        cfg = _with_overrides(load_config(args.config, registry), args)
        opts = _options(args)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    setup_logging(args.log_level or cfg.edged.log_level, cfg.edged.log_file)
    try:
        rt = Runtime(cfg, registry, LiveClock(), options=opts)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    except PluginBuildError as exc:
        log.error("event=startup-failed error=%r", str(exc))
        return EXIT_FAILURE
    try:
        return asyncio.run(run_daemon(rt))
    except PluginBuildError as exc:
        log.error("event=startup-failed error=%r", str(exc))
        return EXIT_FAILURE


# -- replay ---------------------------------------------------------------------
def replay_config(cfg: Config, args: argparse.Namespace, registry: Registry) -> Config:
    """The configuration replay runs: configured outputs except recorders, plus the flags'."""
    outputs = {n: c for n, c in cfg.outputs.items() if c.type != RECORDER_TYPE}
    if args.no_zenoh:
        outputs = {n: c for n, c in outputs.items() if c.type != PUBLISHER_TYPE}
    elif not any(c.type == PUBLISHER_TYPE for c in outputs.values()):
        try:
            cls = registry.get("outputs", PUBLISHER_TYPE)
            outputs[PUBLISHER_TYPE] = cls.Config.model_validate({"type": PUBLISHER_TYPE})
        except PluginNotFound:
            log.warning("event=no-publisher reason='zenoh output not installed; not publishing'")
    if args.record:
        try:
            cls = registry.get("outputs", RECORDER_TYPE)
        except PluginNotFound as exc:
            raise ConfigError("--record", [("--record", str(exc))]) from None
        outputs["record"] = cls.Config.model_validate({"type": RECORDER_TYPE, "path": args.record})
    cfg.outputs = outputs
    return cfg


def print_summary(rt: Runtime, stats: ReplayStats, out: TextIO) -> None:
    """The table at the end of a replay: per source, every counter its input kept."""
    span = ""
    if stats.t_first is not None and stats.t_last is not None:
        span = f", {stats.t_last - stats.t_first:.1f} s of data"
    print(f"replayed {stats.records} records{span}", file=out)
    rows: list[tuple[str, str, int]] = []
    for h in rt.health.components.values():
        if h.role != "input":
            continue
        for k in sorted(h.counters):
            rows.append((h.name, k, h.counters[k]))
    if rows:
        w1 = max(6, *(len(r[0]) for r in rows))
        w2 = max(7, *(len(r[1]) for r in rows))
        print(f"{'source':<{w1}}  {'counter':<{w2}}  {'count':>9}", file=out)
        last = None
        for src, k, v in rows:
            print(f"{(src if src != last else ''):<{w1}}  {k:<{w2}}  {v:>9}", file=out)
            last = src
    if stats.measurements:
        print("measurements by source and kind:", file=out)
        for (src, kind), v in sorted(stats.measurements.items()):
            print(f"  {src:<24} {kind:<18} {v:>9}", file=out)
    for proto, v in sorted(stats.undecodable.items()):
        print(f"records without a decoder ({proto}): {v}", file=out)
    for w in rt.workers:
        print(f"estimator {w.name}: {w.health.counters.get('estimates', 0)} estimates, "
              f"{w.health.counters.get('late', 0)} late, {w.health.counters.get('errors', 0)} errors", file=out)
    for o in rt.outputs:
        state = o.health.state
        err = f" ({o.health.last_error})" if o.health.last_error else ""
        print(f"output {o.name}: {o.health.counters.get('written', 0)} written, {state}{err}", file=out)


def cmd_replay(args: argparse.Namespace, registry: Registry) -> int:
    try:
        cfg = replay_config(_with_overrides(_load(args.config, registry), args), args, registry)
        opts = _options(args)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    if args.speed < 0:
        print("edged replay: --speed must be 0 (as fast as possible) or positive", file=sys.stderr)
        return EXIT_USAGE
    paths = [Path(p) for p in args.inputs]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        print(f"edged replay: no such file: {', '.join(missing)}", file=sys.stderr)
        return EXIT_USAGE
    setup_logging(args.log_level or "warning", None)
    try:
        rt = Runtime(cfg, registry, ReplayClock(), replay=True, options=opts)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    except PluginBuildError as exc:
        print(f"edged replay: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    try:
        stats = asyncio.run(_replay(rt, paths, args))
    except UnknownFormat as exc:
        print(f"edged replay: {exc}", file=sys.stderr)
        return EXIT_USAGE
    print_summary(rt, stats, sys.stdout)
    failed = [o.name for o in rt.outputs if o.health.state in ("backoff", "failed")]
    return EXIT_FAILURE if failed else EXIT_OK


async def _replay(rt: Runtime, paths: list[Path], args: argparse.Namespace) -> ReplayStats:
    bar = None
    if not args.no_progress:
        from tqdm import tqdm

        bar = tqdm(total=None, unit="B", unit_scale=True, desc="replay", disable=None, leave=False)

    def show_progress(done: int, total: int) -> None:
        assert bar is not None
        if bar.total != total:
            bar.total = total
        bar.n = done
        bar.refresh()

    replayer = Replayer(
        rt, paths, speed=args.speed, date=args.date, progress=show_progress if bar is not None else None
    )
    await rt.start()
    try:
        return await replayer.run()
    finally:
        await rt.stop()
        if bar is not None:
            bar.close()
