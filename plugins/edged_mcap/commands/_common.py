"""What every recording command does first: find the file, say clearly what is wrong;
and what each does when the reader of its standard output goes away."""

from __future__ import annotations

import argparse
import functools
import sys
from pathlib import Path
from typing import Callable

from edged.cli import EXIT_FAILURE, EXIT_OK, EXIT_USAGE, stdout_closed

__all__ = ["EXIT_OK", "EXIT_FAILURE", "EXIT_USAGE", "OutputError", "command", "existing_file", "fail"]

Main = Callable[[argparse.Namespace], int]


class OutputError(OSError):
    """Writing the command's own output failed (not reading its input): the name is
    the output's (a file, or standard output)."""


def fail(message: str, code: int = EXIT_FAILURE) -> int:
    print(f"edged: {message}", file=sys.stderr)
    return code


def existing_file(name: str) -> Path | None:
    """The path when it is a readable file; None after printing why not."""
    p = Path(name)
    if not p.is_file():
        fail(f"{p}: no such file", EXIT_USAGE)
        return None
    return p


def command(name: str) -> Callable[[Main], Main]:
    """The `main` of a recording command: standard output closed by its reader
    (`edged inspect FILE | head`) is one line on stderr and exit 1, never a
    BrokenPipeError traceback (neither from the command nor from the interpreter's
    flush at exit)."""

    def wrap(main: Main) -> Main:
        @functools.wraps(main)
        def run(args: argparse.Namespace) -> int:
            try:
                rc = main(args)
                sys.stdout.flush()  # what is still buffered fails here, not at exit
            except BrokenPipeError:
                return stdout_closed(name)
            return rc

        return run

    return wrap
