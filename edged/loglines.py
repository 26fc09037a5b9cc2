"""The lines of a log file, each read with a bound: one way for every line-based reader.

Why: `for line in stream` reads a line whole, however long. A 2 GB candump log of one
line took 4.3 GB of memory, a 512 MB Yacht Devices RAW line 1.18 GB (issue 32). Every
format edged replays has short lines (a CAN frame is under 200 bytes in any of them);
a line longer than `max_line` is garbage or a broken file, counted and skipped, read in
bounded pieces up to its end.
"""

from __future__ import annotations

from typing import BinaryIO, Callable, Iterator

#: Bytes a log line may hold, its line end not counted: twenty times the longest line
#: of any format read here (an iKonvert sentence of a 223-byte fast-packet message).
MAX_LINE = 8192
#: The rejection reason a too-long line is counted under (`rejected.too_long`).
TOO_LONG = "too_long"
#: Bytes read at a time while skipping the rest of a too-long line.
SKIP_CHUNK = 1 << 16


def numbered_lines(
    stream: BinaryIO, reject: Callable[[str, str], None], max_line: int = MAX_LINE
) -> Iterator[tuple[int, bytes]]:
    """(line number from 1, line with its end) for each line of `stream` of at most
    `max_line` bytes before its end; a longer one is `reject(TOO_LONG, message)`ed and skipped (it
    keeps its number, so that the lines after it are named as an editor counts them).
    Memory held: at most max(max_line, SKIP_CHUNK) + 1 bytes of the file."""
    readline = stream.readline
    lineno = 0
    while True:
        line = readline(max_line + 1)
        if not line:
            return
        lineno += 1
        if len(line) > max_line and not line.endswith(b"\n"):
            skipped = len(line)
            while True:
                more = readline(SKIP_CHUNK)
                skipped += len(more)
                if not more or more.endswith(b"\n"):
                    break
            reject(TOO_LONG, f"line {lineno}: {skipped} bytes, longer than a log line may be ({max_line}): skipped")
            continue
        yield lineno, line
