"""`edged run`: the daemon, as systemd runs it (DESIGN §4, §10)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
import sys

from .clock import LiveClock
from .cmdconfig import command_options, with_overrides
from .config import ConfigError, load_config
from .logs import reopen_logs, setup_logging
from .registry import Registry
from .outputhost import OutputHost
from .runtime import PluginBuildError, Runtime
from .sdnotify import Notifier, feed_watchdog, watchdog_period
from .signals import StopSignals
from .subcommand import EXIT_FAILURE, EXIT_OK, EXIT_USAGE

log = logging.getLogger("edged")

#: The output plugin type `--zenoh-config` is for (DESIGN §4).
PUBLISHER_TYPE = "zenoh"


async def run_daemon(rt: Runtime, stop: asyncio.Event | None = None, duration: float | None = None,
                     notifier: Notifier | None = None) -> int:
    """Run until SIGTERM/SIGINT/SIGQUIT (or `stop`, or `duration` seconds); SIGHUP
    rotates. Under systemd (`Type=notify`) it says READY=1 once every plugin has
    started, feeds the watchdog while the loop and every plugin task live, and says
    STOPPING=1 when it stops."""
    loop = asyncio.get_running_loop()
    stop = stop or asyncio.Event()
    installed = _hangup_rotates(loop, rt)
    notifier = notifier if notifier is not None else Notifier()
    feeder: asyncio.Task[None] | None = None
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
    return _stopped(rt, before)


def _hangup_rotates(loop: asyncio.AbstractEventLoop, rt: Runtime) -> list[int]:
    """SIGHUP reopens the log file and rotates the outputs' files (logrotate's
    `postrotate`); the signals installed, to remove at the end."""

    def _hup() -> None:
        log.info("event=sighup action=reopen-logs,rotate")
        reopen_logs()
        rt.rotate()

    try:
        loop.add_signal_handler(signal.SIGHUP, _hup)
        return [signal.SIGHUP]
    except (NotImplementedError, RuntimeError, ValueError):  # not the main thread
        return []


def _stopped(rt: Runtime, before: dict[str, int]) -> int:
    """The exit code of a stop: 1 when the stop itself lost records (an output that
    could not take its last batch, a child killed with it), said and not a clean exit
    (systemd shows it); `before`: each output's loss when the stop began."""
    lost = {o.name: output_loss(o) - before[o.name] for o in rt.outputs}
    lost = {name: n for name, n in lost.items() if n}
    for name, n in sorted(lost.items()):
        o = next(o for o in rt.outputs if o.name == name)
        log.error("event=stopped-with-loss output=%s lost=%d last_error=%r", name, n, o.health.last_error)
    if lost:
        return EXIT_FAILURE
    log.info("event=stopped")
    return EXIT_OK


def output_loss(o: OutputHost) -> int:
    """Records an output lost so far: dropped (any reason) and its queue's overflow."""
    c = o.health.counters
    return sum(v for k, v in c.items() if k.startswith("dropped.")) + c.get("overflow", 0)


def cmd_run(args: argparse.Namespace, registry: Registry) -> int:
    try:
        cfg = with_overrides(load_config(args.config, registry), args)
        opts = command_options(args)
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
