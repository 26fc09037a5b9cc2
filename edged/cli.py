"""The `edged` command line (DESIGN §4).

The argument surface of every subcommand is defined here, in one place, because it is
a contract. The core implements `run`, `replay` and `check-config`; the others are
implemented by plugins registered in the entry point group `edged.commands` under the
subcommand's name and receive the parsed `argparse.Namespace`.

Exit codes: 0 success, 2 bad usage or configuration, 1 runtime failure. A replay
stopped by SIGTERM or SIGINT (Ctrl-C) before the end of its logs closes its outputs,
prints its summary and exits 1: it did not finish. A command whose standard output is
closed by its reader (`edged inspect FILE | head`) says so in one line and exits 1.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import re
import sys
from typing import Sequence

from . import __version__

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse's own exit code is already 2
        self.print_usage(sys.stderr)
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


_DATE = re.compile(r"\d{4}-\d{2}-\d{2}")


def replay_date(text: str) -> str:
    """`--date`: a real calendar day written YYYY-MM-DD (kept as the text)."""
    try:
        if not _DATE.fullmatch(text):
            raise ValueError
        _dt.date.fromisoformat(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a date YYYY-MM-DD: {text!r}") from None
    return text


#: The one message for a `--speed` that cannot be used.
SPEED_RULE = "must be 0 (as fast as possible) or a positive finite factor (1 = real time)"


def replay_speed(text: str) -> float:
    """`--speed`: a finite number (NaN and infinities are refused here; a negative
    one by `edged replay` itself, with the same message and exit code 2)."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{SPEED_RULE}, not {text!r}")
    return v


def positive_seconds(text: str) -> float:
    """A duration in seconds: finite and above zero."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not math.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive finite number of seconds, not {text!r}")
    return v


def seed(text: str) -> int:
    """`edged sim --seed`: a whole number from 0 to 2³² − 1 (numpy's seed range)."""
    try:
        v = int(text)
    except ValueError:
        v = -1
    if not 0 <= v < 2**32:
        raise argparse.ArgumentTypeError(f"must be a whole number from 0 to {2**32 - 1}, not {text!r}")
    return v


def silence_stdout() -> None:
    """After a broken pipe on standard output: point it at /dev/null, so that the
    interpreter's flush at exit does not fail again (and print a traceback)."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(fd, sys.stdout.fileno())
        finally:
            os.close(fd)
    except (OSError, ValueError, AttributeError):  # not a real file (tests): nothing to flush
        pass


def stdout_closed(command: str) -> int:
    """What a command does when the reader of its standard output went away."""
    silence_stdout()
    print(f"edged {command}: standard output closed by its reader (broken pipe): output incomplete", file=sys.stderr)
    return EXIT_FAILURE


def _zenoh_opts(p: argparse.ArgumentParser) -> None:
    p.add_argument("--zenoh-config", metavar="FILE.json5", help="zenoh configuration merged over the safe defaults")
    p.add_argument("--vessel-id", metavar="ID", help="vessel id in the key prefix vessel/<id>")


def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="edged", description="Vessel edge daemon: sensors in, estimates out over Zenoh, MCAP recording.")
    ap.add_argument("--version", action="version", version=f"edged {__version__}")
    ap.add_argument("--log-level", choices=["debug", "info", "warning", "error"], help="override the configured log level")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    p = sub.add_parser("run", help="the daemon (systemd runs this)")
    p.add_argument("-c", "--config", required=True, metavar="CONFIG")
    _zenoh_opts(p)

    p = sub.add_parser("demo", help="run the built-in simulated vessel end to end")
    p.add_argument("--duration", type=positive_seconds, default=None, metavar="S", help="stop after S seconds (default: until Ctrl-C)")
    p.add_argument("--record-dir", metavar="DIR", help="where to record (default ./edged-demo-<UTC start>/)")
    p.add_argument("--no-zenoh", action="store_true", help="do not publish over zenoh")
    _zenoh_opts(p)

    p = sub.add_parser("replay", help="run recorded NMEA, candump or MCAP logs through the pipeline")
    p.add_argument("inputs", nargs="+", metavar="INPUT")
    p.add_argument("-c", "--config", metavar="CONFIG")
    p.add_argument("--speed", type=replay_speed, default=0.0, metavar="0|1|N", help="0: as fast as possible (default), 1: real time")
    p.add_argument("--record", metavar="OUT.mcap", help="record raw data, measurements and estimates to this file")
    p.add_argument("--no-zenoh", action="store_true", help="do not publish over zenoh")
    p.add_argument("--date", type=replay_date, metavar="YYYY-MM-DD", help="date for NMEA logs whose sentences carry only a time of day")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    _zenoh_opts(p)

    p = sub.add_parser("sim", help="simulate a vessel and write its sensor logs and truth")
    p.add_argument("scenario", metavar="SCENARIO")
    p.add_argument("--out", required=True, metavar="DIR")
    p.add_argument("--duration", type=float, default=None, metavar="S")
    p.add_argument("--seed", type=seed, default=0, metavar="N")
    p.add_argument("--waves", metavar="SPEC", default=None,
                   help="the sea instead of the scenario's: regular:AMPLITUDE,PERIOD[,FROM_DEG] or "
                        "jonswap:HS,TP[,FROM_DEG] (m, s, degrees true; FROM_DEG defaults to the scenario's)")

    p = sub.add_parser("inspect", help="channels, counts, rates, time span, gaps of a recording")
    p.add_argument("file", metavar="FILE.mcap")

    p = sub.add_parser("export", help="one topic of a recording as CSV or JSON lines")
    p.add_argument("file", metavar="FILE.mcap")
    p.add_argument("--topic", required=True, metavar="T")
    p.add_argument("--format", choices=["csv", "jsonl"], default="csv")
    p.add_argument("-o", "--output", metavar="OUT", help="default: standard output")

    p = sub.add_parser("plot", help="the pictures an analyst wants, as PNG")
    p.add_argument("file", metavar="FILE.mcap")
    p.add_argument("-o", "--output", required=True, metavar="report.png")
    p.add_argument("--truth", metavar="truth.csv",
                   help="truth table (the simulator's truth.csv): adds the STW error and its autocorrelation")

    p = sub.add_parser("recover", help="make an unfinished recording valid again")
    p.add_argument("file", metavar="FILE.mcap")

    p = sub.add_parser("score", help="estimates of a recording against truth: RMSE, bias, σ coverage")
    p.add_argument("file", metavar="FILE.mcap")
    p.add_argument("--truth", required=True, metavar="truth.csv", help="truth table (the simulator's truth.csv columns)")
    p.add_argument("--warmup", type=float, default=60.0, metavar="S", help="seconds after the first estimate left out (default 60)")
    p.add_argument("--estimate", action="append", metavar="NAME", help="only these estimates (est/NAME); repeatable")
    p.add_argument("--json", action="store_true", help="the figures as JSON instead of a table")

    p = sub.add_parser("router", help="a zenoh router for a ship or a small shore site")
    p.add_argument("--zenoh-config", metavar="FILE.json5")

    p = sub.add_parser("fleet", help="live table of every vessel under vessel/*")
    p.add_argument("--zenoh-config", metavar="FILE.json5")
    p.add_argument("--record", metavar="DIR",
                   help="also record each vessel's estimates and health: DIR/<id>/<id>-<YYYY-MM-DD>.mcap (UTC days)")

    p = sub.add_parser("check-config", help="validate a configuration file")
    p.add_argument("config", metavar="CONFIG")
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from .commands import dispatch

    return dispatch(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
