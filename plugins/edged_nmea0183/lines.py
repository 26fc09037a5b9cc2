"""Bytes to checked NMEA 0183 sentences: line splitting, TAG blocks, epoch prefixes,
checksum policy.

Framing is shared by the live transports and the file reader, so a line is judged the
same way whether it arrives from a serial port or from a log. It never decodes field
values (that is the decoder's job) and it never raises: a line it cannot accept comes
back as the name of the reason, which the caller counts as `rejected.<reason>`.
"""

from __future__ import annotations

import math
from functools import reduce
from operator import xor
from typing import Any, NamedTuple


#: NMEA 0183 allows 82 characters; TAG blocks and proprietary sentences are longer, so
#: the limit is generous but bounded (a stream without line ends must not grow forever).
MAX_LINE = 1024

# Reasons a line is rejected (counted as `rejected.<reason>`).
TOO_LONG = "too_long"
NON_ASCII = "non_ascii"
NO_START = "no_start"  # neither `$` nor `!` (nor a TAG block / epoch before one)
NO_CHECKSUM = "no_checksum"  # policy `require` and no `*hh`
CHECKSUM = "checksum"  # `*hh` present but wrong or not two hex digits
BAD_TAG = "bad_tag"  # TAG block not closed, or its `c:` is not a number
TAG_CHECKSUM = "tag_checksum"
BAD_TIMESTAMP = "bad_timestamp"  # epoch prefix or TAG time not a finite, positive number
NO_TIME = "no_time"  # replay: a line before any time is known (counted by the stamper)
#: replay: a TAG/epoch time outside the log's plausible window (edged.timecheck),
#: e.g. `c:20000000000` (year 2603) or `c:1e300`; counted by the replay reader.
BAD_TIME = "bad_time"

#: Not a rejection: `#` lines are comments (gpsd logs start with a header of them).
COMMENT = "comment"

REJECT_REASONS = (TOO_LONG, NON_ASCII, NO_START, NO_CHECKSUM, CHECKSUM, BAD_TAG, TAG_CHECKSUM, BAD_TIMESTAMP, NO_TIME, BAD_TIME)

_HEX = frozenset(b"0123456789ABCDEFabcdef")
#: `hh` -> its value, for every pair of hex digits: one lookup both checks and converts.
_HEX_PAIRS = {bytes((a, b)): int(bytes((a, b)), 16) for a in _HEX for b in _HEX}
#: Below this many lines numpy's fixed cost per call exceeds what it saves (measured:
#: even at 8 lines; at 1000 lines a chunk costs 0.15 us per line instead of 2 us).
_BATCH_MIN = 8
_DIGITS = frozenset(b"0123456789")
_START = frozenset(b"$!")
_EOL = frozenset(b"\r\n")
_MS_THRESHOLD = 1e11  # DESIGN §3: a TAG/epoch time above this is in milliseconds


class Framed(NamedTuple):
    """One accepted line: the sentence and what preceded it."""

    sentence: bytes  # from `$`/`!` through the checksum, no line end
    tag: str | None  # the TAG block's text between the backslashes, kept for the record
    t_log: float | None  # UTC seconds from the TAG block's `c:` or the epoch prefix


def nmea_checksum(body: bytes) -> int:
    """XOR of the bytes between `$`/`!` and `*` (iterating bytes yields ints)."""
    return reduce(xor, body, 0)


def line_xors(lines: list[bytes]) -> list[int] | None:
    """XOR of all bytes of each line, for a chunk of lines at once (None: too few).

    The checksum is the one per-byte cost of framing; a Python-level XOR over each
    sentence's bytes was a third of the input stage's budget. `frame` turns a line's
    XOR into its checksum by taking out the bytes outside the checksummed span (XOR is
    its own inverse). An empty line's value is meaningless (numpy's `reduceat` gives
    the next byte there), which does not matter: a blank line has no checksum.
    """
    if len(lines) < _BATCH_MIN:
        return None
    np = _numpy()
    if np is None:
        return None
    # The trailing 0 gives an empty last line a valid start index without changing a XOR.
    data = np.frombuffer(b"".join(lines) + b"\0", np.uint8)
    starts = np.zeros(len(lines), np.intp)
    np.cumsum(np.fromiter(map(len, lines), np.intp, len(lines) - 1), out=starts[1:])
    return np.bitwise_xor.reduceat(data, starts).tolist()


_np: Any = None


def _numpy() -> Any:
    """numpy, from the second chunk on (None for the first): importing it costs about
    80 ms, which the first record of a replay must not wait for (issue 34's start-up);
    the first chunk is checked in Python at 2 µs a line."""
    global _np
    if _np is None:
        _np = False
        return None
    if _np is False:
        import numpy

        _np = numpy
    return _np


def _checksum_ok(text: bytes, policy: str, missing: str) -> str | None:
    """Apply the checksum policy to `text` (without its start character).

    Returns None when acceptable, else the reject reason. `missing` is the reason to
    report when there is no `*hh` at all (sentence and TAG block differ).
    """
    if policy == "ignore":
        return None
    star = text.rfind(b"*")
    if star < 0:
        return None if policy == "allow-missing" else missing
    hh = text[star + 1 :]
    if len(hh) != 2 or hh[0] not in _HEX or hh[1] not in _HEX:
        return CHECKSUM if missing == NO_CHECKSUM else TAG_CHECKSUM
    if nmea_checksum(text[:star]) != int(hh, 16):
        return CHECKSUM if missing == NO_CHECKSUM else TAG_CHECKSUM
    return None


def _log_time(text: bytes | str) -> float | None:
    """UNIX seconds from a TAG `c:` value or epoch prefix; None when not usable."""
    try:
        t = float(text)
    except ValueError:
        return None
    if not math.isfinite(t) or t <= 0.0:
        return None
    return t / 1000.0 if t > _MS_THRESHOLD else t


def _split_tag(line: bytes, policy: str) -> tuple[str, float | None, bytes] | str:
    r"""`\tag*hh\rest` -> (tag text, time of `c:` or None, rest) or a reject reason."""
    end = line.find(b"\\", 1)
    if end < 0:
        return BAD_TAG
    raw = line[1:end]
    bad = _checksum_ok(raw, policy, TAG_CHECKSUM)
    if bad is not None:
        return bad
    tag = raw.decode("ascii")
    star = tag.rfind("*")
    t: float | None = None
    for part in (tag[:star] if star >= 0 else tag).split(","):
        if part.startswith("c:"):
            t = _log_time(part[2:])
            if t is None:
                return BAD_TIMESTAMP
    return tag, t, line[end + 1 :]


def frame(line: bytes, policy: str = "require", line_xor: int | None = None) -> Framed | str | None:
    """Judge one line (without its line end).

    Returns a Framed sentence, a reason string (`COMMENT` or one of REJECT_REASONS),
    or None for a blank line (line ends of CR LF pairs and padding are not data).
    `line_xor` is the XOR of all of `line`'s bytes when the caller computed it for a
    whole chunk (`line_xors`); without it the checksum is computed here.
    """
    n = len(line)
    if n > MAX_LINE:
        return TOO_LONG
    line = line.strip()
    if not line:
        return None
    first = line[0]
    if first == 0x23:  # '#': checked before ASCII, headers hold names like "Zeus²"
        return COMMENT
    if not line.isascii():
        return NON_ASCII
    tag: str | None = None
    t_log: float | None = None
    if first == 0x5C:  # '\': NMEA 4.10 TAG block
        split = _split_tag(line, policy)
        if isinstance(split, str):
            return split
        tag, t_log, rest = split
        if line_xor is not None and len(line) == n:
            # Take the block's bytes out of the line's XOR (a short block instead of
            # the whole sentence), so the sentence keeps the chunk's fast checksum.
            line_xor ^= nmea_checksum(line[: len(line) - len(rest)])
            n = len(rest)
        line = rest
    elif first in _DIGITS:  # "1732350000.123 $GPGGA,..."
        head, _, rest = line.partition(b" ")
        rest = rest.lstrip()
        if not rest or rest[0] not in _START:
            return NO_START
        t_log = _log_time(head)
        if t_log is None:
            return BAD_TIMESTAMP
        line = rest
    if len(line) < 2 or line[0] not in _START:
        return NO_START
    # The common case inline (valid `*hh` at the end): this runs for every sentence.
    if policy != "ignore" and len(line) > 4 and line[-3] == 0x2A:
        expected = _HEX_PAIRS.get(line[-2:])
        if expected is not None:
            if line_xor is not None and len(line) == n:  # nothing stripped or split off
                checksum = line_xor ^ line[0] ^ 0x2A ^ line[-2] ^ line[-1]
            else:
                checksum = nmea_checksum(line[1:-3])
            return Framed(line, tag, t_log) if checksum == expected else CHECKSUM
    bad = _checksum_ok(line[1:], policy, NO_CHECKSUM)
    if bad is not None:
        return bad
    return Framed(line, tag, t_log)


class LineSplitter:
    """Cuts a byte stream into lines; CR, LF and CR LF all end a line.

    A line that grows past MAX_LINE without an end is cut off: its first MAX_LINE + 1
    bytes are returned (so that `frame` rejects it as too long, once) and the rest up
    to the next line end is dropped, which bounds memory on a stream of garbage.
    """

    __slots__ = ("_buf", "_discarding")

    def __init__(self) -> None:
        self._buf = b""
        self._discarding = False

    def reset(self) -> None:
        """Forget a partial line (the link was reopened: its tail will never come)."""
        self._buf = b""
        self._discarding = False

    def feed(self, chunk: bytes) -> list[bytes]:
        data = self._buf + chunk if self._buf else chunk
        parts = data.splitlines()  # bytes: splits at \n, \r and \r\n only
        tail = parts.pop() if parts and data[-1] not in _EOL else b""
        if self._discarding and parts:
            parts[0] = b""  # the end of the over-long line already reported
            self._discarding = False
        if self._discarding:
            tail = b""
        elif len(tail) > MAX_LINE:
            parts.append(tail[: MAX_LINE + 1])
            tail = b""
            self._discarding = True
        self._buf = tail
        return parts

    def flush(self) -> list[bytes]:
        """The last line when the stream or datagram ends without a line end."""
        tail, self._buf = self._buf, b""
        self._discarding = False
        return [tail] if tail else []
