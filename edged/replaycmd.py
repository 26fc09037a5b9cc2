"""`edged replay`: recorded logs through the very same pipeline (DESIGN §4, §8)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import signal
import sys
from pathlib import Path

from .clock import ReplayClock
from .cmdconfig import command_options, load_for, with_overrides
from .config import Config, ConfigError
from .logs import setup_logging
from .records import HealthRecord
from .registry import PluginNotFound, Registry
from .logformats import UnknownFormat, detect
from .replay import Replayer, ReplayStats
from .replaysummary import output_failure, print_summary
from .runtime import PluginBuildError, Runtime
from .runcmd import PUBLISHER_TYPE
from .signals import StopSignals
from .subcommand import EXIT_FAILURE, EXIT_OK, EXIT_USAGE, SPEED_RULE, stdout_closed

log = logging.getLogger("edged")

#: The output plugin type the replay flag `--record` refers to (DESIGN §4).
RECORDER_TYPE = "mcap"


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


def cmd_replay(args: argparse.Namespace, registry: Registry) -> int:
    """`edged replay`: exit 0 when every log was replayed and every output took all it
    was given; 1 when an output failed (a recording that could not be written, a
    recorder that stopped) or SIGTERM/SIGINT stopped the replay before its end (the
    outputs are drained and closed, the summary printed all the same); 2 for bad usage
    (a flag, a missing or unreadable input, a `--record` path that cannot be a file)."""
    prepared = _prepare(args, registry)
    if isinstance(prepared, int):
        return prepared
    rt, paths = prepared
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
    return _exit_code(rt, stats, outcome, args)


def _prepare(args: argparse.Namespace, registry: Registry) -> tuple[Runtime, list[Path]] | int:
    """The runtime and the logs of a replay, or the exit code of what makes it
    impossible (bad usage: 2; a plugin that cannot be built: 1), said on stderr."""
    if args.speed < 0:
        print(f"edged replay: --speed {SPEED_RULE}, not {args.speed:g}", file=sys.stderr)
        return EXIT_USAGE
    if args.record:
        problem = record_target_problem(args.record)
        if problem:
            print(f"edged replay: --record {args.record}: {problem}", file=sys.stderr)
            return EXIT_USAGE
    try:
        cfg = replay_config(with_overrides(load_for(args.config, registry), args), args, registry)
        opts = command_options(args)
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
        return Runtime(cfg, registry, ReplayClock(), replay=True, options=opts), paths
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return EXIT_USAGE
    except PluginBuildError as exc:
        print(f"edged replay: {exc}", file=sys.stderr)
        return EXIT_FAILURE


def _exit_code(rt: Runtime, stats: ReplayStats, outcome: ReplayOutcome, args: argparse.Namespace) -> int:
    """1 when an output or an estimator lost anything, or a signal stopped the replay;
    each reason said on stderr. A log whose time stepped back is said, but is the
    log's own doing: not a failure of the replay."""
    rc = EXIT_OK
    if stats.behind:
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


class _ProgressBar:
    """The bytes of the logs read so far, on the terminal (tqdm; nothing when not a tty)."""

    def __init__(self) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=None, unit="B", unit_scale=True, desc="replay", disable=None, leave=False)

    def show(self, done: int, total: int) -> None:
        if self.bar.total != total:
            self.bar.total = total
        self.bar.n = done
        self.bar.refresh()

    def close(self) -> None:
        self.bar.close()


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
    bar = None if args.no_progress else _ProgressBar()
    replayer = Replayer(rt, paths, speed=args.speed, date=args.date, progress=bar.show if bar is not None else None)
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
