"""What every `edged` subcommand shares: the exit codes, the argument types, a broken
standard output, and the contract of a plugin's subcommand (DESIGN §4).

A plugin adds a subcommand by declaring a `Subcommand` under its name in the entry
point group `edged.commands`. It brings its own arguments: `edged` builds the
subcommand's parser with `arguments(parser)` and calls `run(args)` with what it
parsed. The core's own subcommands (`run`, `replay`, `check-config`) are declared
the same way in `edged.commands`, so that there is one way to define a command.

This module imports nothing of the rest of edged: the command line (`edged.cli`), the
core's commands and the plugins' all import it, and it imports none of them.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:  # the registry is only handed through
    from .registry import Registry

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_USAGE = 2


@dataclass(frozen=True)
class Subcommand:
    """One `edged` subcommand.

    `help`: the one line `edged --help` shows. `arguments`: adds the subcommand's
    options to its parser (argparse's `add_argument`). `run`: does the work with the
    parsed namespace and the plugins of this invocation, and returns the exit code
    (0 success, 2 bad usage or configuration, 1 runtime failure).
    """

    help: str
    arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace, "Registry"], int]


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


def zenoh_options(p: argparse.ArgumentParser) -> None:
    """`--zenoh-config` and `--vessel-id`, the same wherever a command talks zenoh."""
    p.add_argument("--zenoh-config", metavar="FILE.json5", help="zenoh configuration merged over the safe defaults")
    p.add_argument("--vessel-id", metavar="ID", help="vessel id in the key prefix vessel/<id>")


def fail(message: str, code: int = EXIT_FAILURE) -> int:
    """Say what went wrong in one line (naming the file); the exit code to return."""
    print(f"edged: {message}", file=sys.stderr)
    return code


def existing_file(name: str) -> Path | None:
    """The path when it is a file; None after saying it is not (bad usage)."""
    p = Path(name)
    if not p.is_file():
        fail(f"{p}: no such file", EXIT_USAGE)
        return None
    return p


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
