"""What every recording command does first: find the file, say clearly what is wrong."""

from __future__ import annotations

import sys
from pathlib import Path

from edged.cli import EXIT_FAILURE, EXIT_OK, EXIT_USAGE

__all__ = ["EXIT_OK", "EXIT_FAILURE", "EXIT_USAGE", "existing_file", "fail"]


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
