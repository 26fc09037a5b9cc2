"""The core's subcommands (`run`, `replay`, `check-config`) and dispatch to plugins'."""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import signal
import sys
from pathlib import Path
from typing import Any, Callable, TextIO

from pydantic import ValidationError

from .clock import LiveClock, ReplayClock
from .cli import EXIT_FAILURE, EXIT_OK, EXIT_USAGE, SPEED_RULE, stdout_closed
from .config import Config, ConfigError, default_config, load_config
from .health import OK_STATES
from .logs import reopen_logs, setup_logging
from .records import HealthRecord
from .registry import PluginNotFound, Registry
from .replay import Replayer, ReplayStats, UnknownFormat, detect, utc_iso
from .runtime import OutputHost, PluginBuildError, Runtime
from .sdnotify import Notifier, feed_watchdog, watchdog_period
from .signals import StopSignals

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
    try:
        rc = int(plugin_cmd(args))
        sys.stdout.flush()  # what is still buffered fails here, not at the interpreter's exit
        return rc
    except BrokenPipeError:  # `edged score ... | head`: the reader went away
        return stdout_closed(args.command)


def _load(path: str | None, registry: Registry) -> Config:
    return load_config(path, registry) if path else default_config(registry)


def _with_overrides(cfg: Config, args: argparse.Namespace) -> Config:
    if getattr(args, "vessel_id", None) is not None:
        try:
            cfg.edged = cfg.edged.model_validate({**cfg.edged.model_dump(), "vessel_id": args.vessel_id})
        except ValidationError as exc:
            raise ConfigError("--vessel-id", [("vessel_id", e["msg"]) for e in exc.errors()]) from None
    return cfg


def _options(args: argparse.Namespace) -> dict[str, Any]:
    opts: dict[str, Any] = {}
    zc = getattr(args, "zenoh_config", None)
    if zc:
        p = Path(zc)
        if not p.is_file():
            raise ConfigError(str(p), [("--zenoh-config", "no such file")])
        try:
            p.read_bytes().decode("utf-8")
        except OSError as exc:
            raise ConfigError(str(p), [("--zenoh-config", f"cannot read: {exc.strerror or exc}")]) from None
        except UnicodeDecodeError as exc:
            raise ConfigError(str(p), [("--zenoh-config", f"not a json5 text file (byte {exc.start} is no UTF-8)")]) from None
        opts["zenoh_config"] = str(p.resolve())
    return opts


def cmd_check_config(args: argparse.Namespace, registry: Registry) -> int:
    """What `run` would refuse, refused here alike: the schemas, then what only the
    built plugins can judge (their `check()`, estimators consuming what no instance
    makes or each other in a cycle). Nothing is started. Warnings (what works but is
    risky, such as an unguarded zenoh input) are logged on stderr; the exit code stays 0."""
    setup_logging(getattr(args, "log_level", None) or "warning")
    try:
        cfg = load_config(args.config, registry)
        Runtime(cfg, registry, ReplayClock())
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    except PluginBuildError as exc:
        print(f"{args.config}: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    parts = [f"{len(getattr(cfg, r))} {r} ({', '.join(getattr(cfg, r)) or '-'})" for r in ("inputs", "estimators", "outputs")]
    print(f"{args.config}: OK: vessel {cfg.edged.vessel_id}; " + "; ".join(parts))
    return EXIT_OK


# -- run ------------------------------------------------------------------------
async def run_daemon(rt: Runtime, stop: asyncio.Event | None = None, duration: float | None = None,
                     notifier: Notifier | None = None) -> int:
    """Run until SIGTERM/SIGINT/SIGQUIT (or `stop`, or `duration` seconds); SIGHUP
    rotates. Under systemd (`Type=notify`) it says READY=1 once every plugin has
    started, feeds the watchdog while the loop and every plugin task live, and says
    STOPPING=1 when it stops."""
    loop = asyncio.get_running_loop()
    stop = stop or asyncio.Event()
    installed: list[int] = []
    notifier = notifier if notifier is not None else Notifier()
    feeder: asyncio.Task[None] | None = None

    def _hup() -> None:
        log.info("event=sighup action=reopen-logs,rotate")
        reopen_logs()
        rt.rotate()

    try:
        loop.add_signal_handler(signal.SIGHUP, _hup)
        installed.append(signal.SIGHUP)
    except (NotImplementedError, RuntimeError, ValueError):  # not the main thread
        pass
    stops = StopSignals(loop, lambda sig: stop.set(), rt.config.edged.shutdown_timeout).install()
    try:
        await rt.start()
        log.info(
            "event=started vessel=%s inputs=%d estimators=%d outputs=%d",
            rt.config.edged.vessel_id,
            len(rt.inputs),
            len(rt.workers),
            len(rt.outputs),
        )
        notifier.ready(f"running: vessel {rt.config.edged.vessel_id}, {len(rt.inputs)} inputs, "
                       f"{len(rt.workers)} estimators, {len(rt.outputs)} outputs")
        period = watchdog_period()
        if period is not None and notifier.enabled:
            feeder = loop.create_task(feed_watchdog(notifier, period, rt.ended_tasks), name="watchdog")
        if duration is None:
            await stop.wait()
        else:
            try:
                await asyncio.wait_for(stop.wait(), duration)
            except asyncio.TimeoutError:
                pass
        log.info("event=stopping")
    finally:
        notifier.stopping()
        if feeder is not None:
            feeder.cancel()
        before = {o.name: output_loss(o) for o in rt.outputs}
        await rt.stop()
        notifier.close()
        stops.remove()
        for sig in installed:
            loop.remove_signal_handler(sig)
    lost = {o.name: output_loss(o) - before[o.name] for o in rt.outputs}
    lost = {name: n for name, n in lost.items() if n}
    if lost:
        # The stop itself lost records (an output that could not take its last batch,
        # a child killed with it): said, and not a clean exit (systemd shows it).
        for name, n in sorted(lost.items()):
            o = next(o for o in rt.outputs if o.name == name)
            log.error("event=stopped-with-loss output=%s lost=%d last_error=%r", name, n, o.health.last_error)
        return EXIT_FAILURE
    log.info("event=stopped")
    return EXIT_OK


def output_loss(o: OutputHost) -> int:
    """Records an output lost so far: dropped (any reason) and its queue's overflow."""
    c = o.health.counters
    return sum(v for k, v in c.items() if k.startswith("dropped.")) + c.get("overflow", 0)


def cmd_run(args: argparse.Namespace, registry: Registry) -> int:
    try:
        cfg = _with_overrides(load_config(args.config, registry), args)
        opts = _options(args)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    setup_logging(args.log_level or cfg.edged.log_level, cfg.edged.log_file)
    if "zenoh_config" in opts and not any(c.type == PUBLISHER_TYPE for c in (*cfg.inputs.values(), *cfg.outputs.values())):
        log.warning("event=option-unused option=--zenoh-config file=%r reason='no zenoh input or output is configured: "
                    "the file is not used'", opts["zenoh_config"])
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


def _logs_only(paths: list[Path], registry: Registry) -> list[Path]:
    """The files a log reader recognises; each other one named on stderr and skipped.
    `edged replay DIR/*` after `edged sim --out DIR` meets meta.json and truth.csv
    beside the logs: the logs are replayed (exit 0) and the rest named; only when no
    file is left is it bad usage (the caller exits 2)."""
    logs = []
    for p in paths:
        try:
            detect(p, registry)
        except UnknownFormat as exc:
            print(f"edged replay: skipped {exc}", file=sys.stderr)
            continue
        logs.append(p)
    if not logs:
        print(f"edged replay: none of the {len(paths)} file(s) is a log any reader recognises", file=sys.stderr)
    return logs


def record_target_problem(target: str) -> str | None:
    """Why `--record OUT` cannot be recorded into, when that can be told before the
    replay starts (bad usage, exit 2); None when it looks writable. Missing folders are
    created by the recorder."""
    p = Path(target)
    if p.is_dir():
        return "is a directory (give the file to write, e.g. OUT.mcap)"
    if p.exists():
        if not p.is_file():
            return "is not a regular file"
        if _no_storage(p):
            return _NO_STORAGE
        return None if os.access(p, os.W_OK) else "is not writable"
    folder = p.parent
    while not folder.exists():
        if folder == folder.parent:
            break
        folder = folder.parent
    if not folder.is_dir():
        return f"{folder} is not a directory"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"cannot create files in {folder}"
    if _no_storage(folder):
        return _NO_STORAGE
    return None


_NO_STORAGE = "is on a filesystem without storage (such as /proc or /sys): nothing can be recorded there"


def _no_storage(path: Path) -> bool:
    """A kernel's virtual filesystem (proc, sysfs) reports no blocks at all; a real
    disk, however full, reports its size (a full one is the recorder's disk floor's)."""
    try:
        return os.statvfs(path).f_blocks == 0
    except OSError:
        return False


def _counted(counters: dict[str, int], prefix: str) -> tuple[int, str]:
    """The sum of the counters `prefix.*` and their list ("" when none)."""
    items = sorted((k[len(prefix) + 1:], v) for k, v in counters.items() if k.startswith(prefix + ".") and v)
    return sum(v for _, v in items), ", ".join(f"{k} {v}" for k, v in items)


def output_failure(o: OutputHost, state: str) -> str | None:
    """Why output `o` did not take everything a replay gave it (None when it did).

    `state` is the output's state before the replay stopped it. An output failed when
    it raised (restarted by its supervisor: the batch in hand is lost), was in a failed
    state, stopped on its own (`stops.<state>`: a recorder's full disk or write error)
    or dropped anything (`dropped.<reason>`, `overflow` of its queue)."""
    h = o.health
    c = h.counters
    why = []
    if h.restarts:
        why.append(f"failed {h.restarts} time(s)")
    if state in ("backoff", "failed", "disk_full", "disk_low"):
        why.append(f"ended {state}")
    stops, stop_list = _counted(c, "stops")
    if stops:
        why.append(f"stopped ({stop_list})")
    dropped, _ = _counted(c, "dropped")
    if dropped:
        why.append(f"dropped {dropped}")
    if c.get("overflow"):
        why.append(f"queue overflow {c['overflow']}")
    if not why:
        return None
    err = f": {h.last_error}" if h.last_error else ""
    return "; ".join(why) + err


def _output_line(o: OutputHost, state: str) -> str:
    """One output's counts: records handed to it, and what it made of them (for a
    recorder: messages that reached the file, dropped and rejected, by reason)."""
    c = o.health.counters
    parts = [f"{c.get('written', 0)} records handed over"]
    if "recorded" in c or getattr(o.plugin, "files", None) is not None:
        parts.append(f"{c.get('recorded', 0)} messages recorded")
        for prefix in ("dropped", "rejected"):
            n, items = _counted(c, prefix)
            parts.append(f"{n} {prefix}" + (f" ({items})" if items else ""))
        files = [str(f) for f in getattr(o.plugin, "files", None) or []]
        if files:
            parts.append("into " + ", ".join(files))
    else:
        skip = {"written", "errors"}
        parts += [f"{k} {v}" for k, v in sorted(c.items()) if k not in skip and v]
    err = f" ({o.health.last_error})" if o.health.last_error else ""
    said = f"ok ({state} to the end)" if state in OK_STATES else state
    return f"output {o.name}: {', '.join(parts)}; {said}{err}"




def print_summary(
    rt: Runtime,
    stats: ReplayStats,
    out: TextIO,
    *,
    states: dict[str, str] | None = None,
    interrupted: str | None = None,
) -> None:
    """The table at the end of a replay: per source, every counter its input kept.

    `states`: each output's state before the replay stopped it (its state now is
    `stopped`); `interrupted`: the signal that stopped the replay before its end."""
    states = states or {}
    if interrupted is not None:
        at = utc_iso(rt.clock.now()) if stats.t_first is not None else "its start"
        print(f"replay interrupted at {at} (data time) by {interrupted}", file=out)
        if stats.t_first is not None:
            print(f"replayed {rt.clock.now() - stats.t_first:.1f} s of data", file=out)
    else:
        span = ""
        if stats.t_first is not None and stats.t_last is not None:
            span = f", {stats.t_last - stats.t_first:.1f} s of data"
        print(f"replayed {stats.records} records{span}", file=out)
    if stats.bad_time:
        print(f"records refused by the replay for a time that cannot be true: {stats.bad_time}", file=out)
    if stats.gaps_skipped:
        print(f"gaps in the data skipped instead of waited for (--speed pacing): {stats.gaps_skipped}", file=out)
    for src, (index, now, t) in sorted(stats.stepped_back.items()):
        print(f"time stepped back: {src} by {now - t:.1f} s at its record {index} (to {utc_iso(t)}, after "
              f"{utc_iso(now)}); {stats.behind[src]} of its records behind the replay's clock reached no "
              f"estimator (two logs in one? replay them one at a time)", file=out)
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
        print(_output_line(o, states.get(o.name, o.health.state)), file=out)


def cmd_replay(args: argparse.Namespace, registry: Registry) -> int:
    """`edged replay`: exit 0 when every log was replayed and every output took all it
    was given; 1 when an output failed (a recording that could not be written, a
    recorder that stopped) or SIGTERM/SIGINT stopped the replay before its end (the
    outputs are drained and closed, the summary printed all the same); 2 for bad usage
    (a flag, a missing or unreadable input, a `--record` path that cannot be a file)."""
    if args.speed < 0:
        print(f"edged replay: --speed {SPEED_RULE}, not {args.speed:g}", file=sys.stderr)
        return EXIT_USAGE
    if args.record:
        problem = record_target_problem(args.record)
        if problem:
            print(f"edged replay: --record {args.record}: {problem}", file=sys.stderr)
            return EXIT_USAGE
    try:
        cfg = replay_config(_with_overrides(_load(args.config, registry), args), args, registry)
        opts = _options(args)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    paths = [Path(p) for p in args.inputs]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        print(f"edged replay: no such file: {', '.join(missing)}", file=sys.stderr)
        return EXIT_USAGE
    paths = _logs_only(paths, registry)
    if not paths:
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
    outcome = ReplayOutcome()
    try:
        stats = asyncio.run(_replay(rt, paths, args, outcome))
    except UnknownFormat as exc:
        print(f"edged replay: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:  # a Ctrl-C outside the replay loop (start-up, shutdown)
        print("edged replay: interrupted", file=sys.stderr)
        return EXIT_FAILURE
    try:
        print_summary(rt, stats, sys.stdout, states=outcome.states, interrupted=outcome.interrupted)
        sys.stdout.flush()
    except BrokenPipeError:
        return stdout_closed("replay")
    rc = EXIT_OK
    if stats.behind:  # the log's own doing, said; not a failure of the replay (exit 0)
        print(f"edged replay: the time of {', '.join(sorted(stats.behind))} stepped back: "
              f"{sum(stats.behind.values())} records reached no estimator", file=sys.stderr)
    for o in rt.outputs:
        why = output_failure(o, outcome.states.get(o.name, o.health.state))
        if why is not None:
            target = f" ({args.record})" if o.name == "record" and args.record else ""
            print(f"edged replay: output {o.name}{target}: {why}", file=sys.stderr)
            rc = EXIT_FAILURE
    for w in rt.workers:
        lost = sum(v for k, v in w.health.counters.items() if k.startswith("dropped.") or k == "overflow")
        if w.gave_up:
            print(f"edged replay: estimator {w.name}: {w.health.last_error} (gave up; its inputs were dropped)", file=sys.stderr)
            rc = EXIT_FAILURE
        elif lost:
            print(f"edged replay: estimator {w.name}: lost {lost} inputs (last error: {w.health.last_error})", file=sys.stderr)
            rc = EXIT_FAILURE
    if outcome.interrupted is not None:
        rc = EXIT_FAILURE
    return rc


class ReplayOutcome:
    """What `_replay` leaves for the exit code: the signal that stopped it (if one
    did) and each output's state before the runtime stopped them all."""

    def __init__(self) -> None:
        self.interrupted: str | None = None
        self.states: dict[str, str] = {}


async def _replay(
    rt: Runtime, paths: list[Path], args: argparse.Namespace, outcome: ReplayOutcome | None = None
) -> ReplayStats:
    """Replay `paths` through `rt`. SIGTERM and SIGINT stop it as they stop the daemon:
    no more records are read, what is queued is processed, the outputs are drained and
    closed (a recording is finished, with its summary); `outcome.interrupted` names
    the signal."""
    outcome = outcome if outcome is not None else ReplayOutcome()
    loop = asyncio.get_running_loop()
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
    task: asyncio.Task[ReplayStats] | None = None

    def on_signal(sig: signal.Signals) -> None:
        if outcome.interrupted is not None:
            return  # already stopping: the outputs are being drained and closed
        outcome.interrupted = sig.name
        log.info("event=replay-stopping signal=%s t=%s", sig.name, rt.clock.now())
        if task is not None:
            task.cancel()

    stops = StopSignals(loop, on_signal, rt.config.edged.shutdown_timeout, hangup_stops=True).install()
    try:
        await rt.start()
        task = loop.create_task(replayer.run(), name="replay")
        if outcome.interrupted is not None:  # a signal while the outputs opened
            task.cancel()
        try:
            return await task
        except asyncio.CancelledError:
            if outcome.interrupted is None or not task.cancelled():
                raise  # not ours: whoever cancelled this coroutine
            stats = replayer.stats
            stats.t_last = rt.clock.now() if stats.t_first is not None else None
            # What a finished replay ends with: the workers' last steps, the health.
            await rt.finish_workers()
            snap = rt.health_snapshot()
            rt.router.publish(HealthRecord(snap["t"], snap))
            return stats
    finally:
        if task is not None and not task.done():
            task.cancel()
        outcome.states = {o.name: o.health.state for o in rt.outputs}
        await rt.stop()
        stops.remove()
        if bar is not None:
            bar.close()
