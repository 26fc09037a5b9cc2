"""What every recording command does first: find the file, say clearly what is wrong.
(A reader of standard output that goes away is `edged.commands.dispatch`'s.)"""

from __future__ import annotations

import sys
from pathlib import Path

from edged.subcommand import EXIT_FAILURE, EXIT_OK, EXIT_USAGE

__all__ = ["EXIT_OK", "EXIT_FAILURE", "EXIT_USAGE", "OutputError", "existing_file", "fail"]


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
