"""The core's subcommands (`run`, `replay`, `check-config`), declared as every
plugin's are (`edged.subcommand.Subcommand`), and the dispatch of a parsed command
line to the subcommand it names."""

from __future__ import annotations

import argparse
import logging
import sys

from .clock import ReplayClock
from .config import ConfigError, load_config
from .logs import setup_logging
from .registry import PluginNotFound, Registry
from .replaycmd import cmd_replay
from .runcmd import cmd_run
from .runtime import PluginBuildError, Runtime
from .subcommand import (
    EXIT_FAILURE, EXIT_OK, EXIT_USAGE, Subcommand, replay_date, replay_speed, stdout_closed, zenoh_options,
)

log = logging.getLogger("edged")


def dispatch(args: argparse.Namespace, registry: Registry | None = None) -> int:
    """Run the parsed subcommand: the core's, or the plugin's that declared it."""
    registry = registry or Registry()
    cmd: Subcommand | None = CORE_COMMANDS.get(args.command)
    if cmd is not None:
        return cmd.run(args, registry)
    try:
        cmd = registry.get("commands", args.command)
    except PluginNotFound:
        print(
            f"edged {args.command}: not available in this installation "
            f"(no plugin provides the command; entry point group edged.commands)",
            file=sys.stderr,
        )
        return EXIT_FAILURE
    setup_logging(args.log_level or "info")
    try:
        rc = int(cmd.run(args, registry))
        sys.stdout.flush()  # what is still buffered fails here, not at the interpreter's exit
        return rc
    except BrokenPipeError:  # `edged score ... | head`: the reader went away
        return stdout_closed(args.command)


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




def _run_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-c", "--config", required=True, metavar="CONFIG")
    zenoh_options(p)


def _replay_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("inputs", nargs="+", metavar="INPUT")
    p.add_argument("-c", "--config", metavar="CONFIG")
    p.add_argument("--speed", type=replay_speed, default=0.0, metavar="0|1|N", help="0: as fast as possible (default), 1: real time")
    p.add_argument("--record", metavar="OUT.mcap", help="record raw data, measurements and estimates to this file")
    p.add_argument("--no-zenoh", action="store_true", help="do not publish over zenoh")
    p.add_argument("--date", type=replay_date, metavar="YYYY-MM-DD", help="date for NMEA logs whose sentences carry only a time of day")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    zenoh_options(p)


def _check_config_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", metavar="CONFIG")


#: The core's subcommands, first in `edged --help`; a plugin cannot take their names.
CORE_COMMANDS: dict[str, Subcommand] = {
    "run": Subcommand("the daemon (systemd runs this)", _run_arguments, cmd_run),
    "replay": Subcommand("run recorded NMEA, candump or MCAP logs through the pipeline", _replay_arguments, cmd_replay),
    "check-config": Subcommand("validate a configuration file", _check_config_arguments, cmd_check_config),
}
