"""candump logs -> RawRecords, in the three layouts can-utils has written over the years.

- `candump -l` (the log format):     `(1732350000.123456) can0 09F11201#0011...`
- `candump` screen output, with or without `-t a`:
                                      `(1502984866.421964)  can0  09F112CC   [8]  FF 72 ...`
                                      `  can0  09F8027F   [8]  00 FC FF FF 00 00 FF FF`
- old candump (≤ 2012):               `<0x18eeff01> [8] 05 a0 be 1c 00 a0 a0 c0`

An identifier of more than three hex digits is a 29-bit one (candump prints 11-bit
identifiers with three). Formats that merely look similar (Actisense/YDWG text,
iKonvert, canboat's own) are not candump: `sniff` says no, and edged tells the user.
Lines without a timestamp are stamped 0.0 and counted (`untimed`): a log without time
can be decoded but not placed in time, and that must be visible.
"""

from __future__ import annotations

from typing import BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.records import RawRecord

#: bit of the identifier that marks a SocketCAN error frame in `-l` logs
_CAN_ERR_FLAG = 0x20000000
_HEADER_PREFIXES = (b"#", b"interface =")


class _Skip(Exception):
    """A well-formed line that carries no data frame (remote or error frame)."""

    def __init__(self, counter: str) -> None:
        self.counter = counter


def _ident(text: bytes) -> tuple[int, bool]:
    can_id = int(text, 16)
    ext = len(text) > 3
    if can_id >= (1 << 29 if ext else 1 << 11):
        raise ValueError(f"identifier {text!r} out of range")
    return can_id, ext


def _log_frame(iface: bytes, frame: bytes) -> tuple[bytes, int, bool, bytes]:
    """`ID#DATA`, `ID#R` (remote), `ID##<flags><DATA>` (CAN FD)."""
    ident, sep, data = frame.partition(b"#")
    if not sep:
        raise ValueError("no '#'")
    if len(ident) == 8 and int(ident, 16) & _CAN_ERR_FLAG:
        raise _Skip("error_frames")
    can_id, ext = _ident(ident)
    if data[:1] in (b"R", b"r"):
        raise _Skip("remote_frames")
    if data[:1] == b"#":  # FD: one hex digit of flags, then the data
        data = data[2:]
    return iface, can_id, ext, bytes.fromhex(data.decode("ascii"))


def _parse(line: bytes) -> tuple[float | None, bytes | None, int, bool, bytes]:
    """(time, interface, id, extended, data) of one line; ValueError if not candump."""
    t: float | None = None
    if line[:1] == b"(":
        stamp, sep, line = line[1:].partition(b")")
        if not sep:
            raise ValueError("unclosed '('")
        t = float(stamp)
    tok = line.split()
    if len(tok) == 2 and b"#" in tok[1]:
        return (t, *_log_frame(tok[0], tok[1]))
    if len(tok) >= 2 and tok[0][:3] == b"<0x" and tok[0][-1:] == b">":
        iface: bytes | None = None
        ident, rest = tok[0][3:-1], tok[1:]
    elif len(tok) >= 3:
        iface, ident, rest = tok[0], tok[1], tok[2:]
    else:
        raise ValueError("too few fields")
    dlc_tok = rest[0]
    if dlc_tok[:1] != b"[" or dlc_tok[-1:] != b"]":
        raise ValueError("no [dlc]")
    dlc = int(dlc_tok[1:-1])
    if len(rest) > 1 and rest[1] == b"remote":
        raise _Skip("remote_frames")
    octets = rest[1 : 1 + dlc]
    if len(octets) != dlc or any(len(o) != 2 for o in octets):
        raise ValueError(f"expected {dlc} data bytes")
    can_id, ext = _ident(ident)
    return t, iface, can_id, ext, bytes.fromhex(b"".join(octets).decode("ascii"))


def _meaningful(line: bytes) -> bool:
    s = line.strip()
    return bool(s) and not s.startswith(_HEADER_PREFIXES)


def sniff(head: bytes) -> bool:
    """True when the first data line of `head` is a candump line."""
    lines = head.splitlines()
    if len(lines) > 1 and not head.endswith((b"\n", b"\r")):
        lines = lines[:-1]  # the head may end inside a line
    for line in lines:
        if not _meaningful(line):
            continue
        try:
            _parse(line.strip())
        except _Skip:
            return True
        except (ValueError, UnicodeDecodeError):
            return False
        return True
    return False


def read(stream: BinaryIO, source: str, health: ComponentHealth, *, bus_from_line: bool) -> Iterator[RawRecord]:
    """RawRecords of a candump log in file order; bad lines are counted and skipped.

    With `bus_from_line` the record's source is the interface the line names (`can0`),
    so that several files of one bus share one decoder (a fast-packet message split
    across two files is reassembled); otherwise, or where the line names none, `source`.
    """
    fallback = source.encode()
    untimed = False
    for lineno, line in enumerate(stream, 1):
        if not _meaningful(line):
            continue
        try:
            t, iface, can_id, ext, data = _parse(line.strip())
        except _Skip as skip:
            health.count(skip.counter)
            continue
        except (ValueError, UnicodeDecodeError) as exc:
            health.count("rejected.bad_line")
            health.error(f"line {lineno}: not a candump frame ({exc})")
            continue
        if t is None:
            t = 0.0
            health.count("untimed")
            if not untimed:
                untimed = True
                health.error(f"line {lineno}: candump log without timestamps, frames stamped 0.0")
        bus = (iface if bus_from_line and iface else fallback).decode("ascii", "replace")
        yield RawRecord("can", bus, t, data, {"id": can_id, "ext": ext})
