"""The `edged` command line (DESIGN §4).

Every subcommand is a `edged.subcommand.Subcommand`: the core's (`run`, `replay`,
`check-config`) in `edged.commands`, the others in plugins, registered in the entry
point group `edged.commands` under the subcommand's name. Each brings its own
arguments. Only the subcommand asked for is loaded; `edged --help`, and a parser
built without naming one, load them all.

Exit codes: 0 success, 2 bad usage or configuration, 1 runtime failure. A replay
stopped by SIGTERM or SIGINT (Ctrl-C) before the end of its logs closes its outputs,
prints its summary and exits 1: it did not finish. A command whose standard output is
closed by its reader (`edged inspect FILE | head`) says so in one line and exits 1.
"""

from __future__ import annotations

import argparse
import logging
import sys
from typing import Sequence

from . import __version__
from .commands import CORE_COMMANDS, dispatch
from .registry import Registry
from .subcommand import EXIT_USAGE, Subcommand

log = logging.getLogger("edged")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse's own exit code is already 2
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _command_named(argv: Sequence[str] | None) -> str | None:
    """The subcommand `argv` names: its first word that is not an option (edged's
    own options take no value but `--log-level`'s)."""
    words = list(sys.argv[1:] if argv is None else argv)
    i = 0
    while i < len(words):
        w = words[i]
        if w == "--log-level":
            i += 2
            continue
        if not w.startswith("-"):
            return w
        i += 1
    return None


def _subcommands(registry: Registry, only: str | None) -> dict[str, Subcommand]:
    """The core's subcommands, then the plugins' (`only`: just that one, if a plugin
    has it). A plugin whose declaration is not a `Subcommand` is left out with a
    warning, as a broken plugin must not take the others' commands away."""
    found: dict[str, Subcommand] = dict(CORE_COMMANDS)
    if only in found:
        return found
    names = [only] if only is not None and only in registry.names("commands") else registry.names("commands")
    for name in names:
        if name in found:
            continue
        try:
            cmd = registry.get("commands", name)
        except Exception as exc:
            log.warning("command=%s load failed: %s", name, exc)
            continue
        if isinstance(cmd, Subcommand):
            found[name] = cmd
        else:
            log.warning("command=%s is not an edged.subcommand.Subcommand; left out", name)
    return found


def build_parser(argv: Sequence[str] | None = (), registry: Registry | None = None) -> argparse.ArgumentParser:
    """The parser of `argv`'s subcommand, or of every subcommand (`argv` empty, the
    default, as tests and `--help` want)."""
    registry = registry or Registry()
    ap = _Parser(prog="edged", description="Vessel edge daemon: sensors in, estimates out over Zenoh, MCAP recording.")
    ap.add_argument("--version", action="version", version=f"edged {__version__}")
    ap.add_argument("--log-level", choices=["debug", "info", "warning", "error"], help="override the configured log level")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name, cmd in _subcommands(registry, _command_named(argv) if argv else None).items():
        cmd.arguments(sub.add_parser(name, help=cmd.help))
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    registry = Registry()
    args = build_parser(sys.argv[1:] if argv is None else argv, registry).parse_args(argv)
    return dispatch(args, registry)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
