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

import re
from typing import Any, BinaryIO, Callable, Iterator

from edged.health import ComponentHealth
from edged.loglines import numbered_lines
from edged.records import RawRecord
from edged.timecheck import BAD_TIME, DEFAULT_LIMITS, TimeLimits, TimeWindow

from .formats import rejecter

#: bit of the identifier that marks a SocketCAN error frame in `-l` logs
_CAN_ERR_FLAG = 0x20000000
_HEADER_PREFIXES = (b"#", b"interface =")
# Strict shapes (Python's int() and float() also take "+12", "1_2", " 10 ", "inf").
_HEX_ID = re.compile(rb"[0-9A-Fa-f]{1,8}")
_STAMP = re.compile(rb"[0-9]+(?:\.[0-9]*)?")
_DLC = re.compile(rb"[0-9]{1,3}")
#: A Linux interface name: printable ASCII without space or `/`; IFNAMSIZ is 16.
_IFACE = re.compile(rb"[!-.0-~]{1,15}")
#: A classic `candump -l` line, all of it strictly shaped (the reader's fast path).
_FAST = re.compile(rb"\(([0-9]+\.[0-9]+)\) ([!-.0-~]{1,15}) ([0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})#((?:[0-9A-Fa-f]{2}){0,8})\r?\n?")
#: Data lengths a CAN FD frame can have (a classic frame: 0..8).
_FD_LENGTHS = frozenset((0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64))


class _Skip(Exception):
    """A well-formed line that carries no data frame (remote or error frame)."""

    def __init__(self, counter: str) -> None:
        self.counter = counter


class _Reject(ValueError):
    """A candump line whose identifier, length, interface or time cannot be true
    (counted as `rejected.<reason>`; `sniff` still knows the format by it)."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


def _ident(text: bytes) -> tuple[int, bool]:
    if _HEX_ID.fullmatch(text) is None:
        try:
            int(text, 16)  # what the reader used to accept: "-12", "+12", "1_2", "0x123"
        except ValueError:
            raise ValueError(f"identifier {text!r} is not hex") from None
        raise _Reject("bad_id", f"identifier {text!r} is not 1 to 8 hex digits")
    can_id = int(text, 16)
    ext = len(text) > 3
    if can_id >= (1 << 29 if ext else 1 << 11):
        raise ValueError(f"identifier {text!r} out of range")
    return can_id, ext


def _length(n: int, fd: bool) -> None:
    if fd:
        if n not in _FD_LENGTHS:
            raise _Reject("bad_length", f"{n} data bytes: not a CAN FD length")
    elif n > 8:
        raise _Reject("bad_length", f"{n} data bytes in a classic CAN frame (at most 8)")


def _iface(name: bytes) -> bytes:
    if _IFACE.fullmatch(name) is None:
        raise _Reject("bad_interface", f"interface name {name[:32]!r} is not a printable ASCII name")
    return name


def _log_frame(iface: bytes, frame: bytes) -> tuple[bytes, int, bool, bytes]:
    """`ID#DATA`, `ID#R` (remote), `ID##<flags><DATA>` (CAN FD)."""
    ident, sep, data = frame.partition(b"#")
    if not sep:
        raise ValueError("no '#'")
    if len(ident) == 8 and _HEX_ID.fullmatch(ident) is not None and int(ident, 16) & _CAN_ERR_FLAG:
        raise _Skip("error_frames")
    can_id, ext = _ident(ident)
    if data[:1] in (b"R", b"r"):
        raise _Skip("remote_frames")
    fd = data[:1] == b"#"
    if fd:  # FD: one hex digit of flags, then the data
        if data[1:2] not in _HEX_DIGITS:
            raise ValueError("CAN FD flags are not a hex digit")
        data = data[2:]
    payload = bytes.fromhex(data.decode("ascii"))
    _length(len(payload), fd)
    return _iface(iface), can_id, ext, payload


_HEX_DIGITS = frozenset(bytes((c,)) for c in b"0123456789ABCDEFabcdef")


def _parse(line: bytes) -> tuple[float | None, bytes | None, int, bool, bytes]:
    """(time, interface, id, extended, data) of one line; ValueError if not candump,
    `_Reject` (a ValueError) if candump with a value that cannot be true. A time that
    is not a plain non-negative decimal number is NaN (the caller's window refuses
    it), so that its line is counted as `bad_time` once the rest is known to be a frame."""
    t: float | None = None
    if line[:1] == b"(":
        stamp, sep, line = line[1:].partition(b")")
        if not sep:
            raise ValueError("unclosed '('")
        if _STAMP.fullmatch(stamp) is not None:
            t = float(stamp)
        else:
            try:
                float(stamp)  # "inf", "nan", "-1", "1e300": a number, not a time
            except ValueError:
                raise ValueError(f"time {stamp[:32]!r} is not a number") from None
            t = float("nan")
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
    if dlc_tok[:1] != b"[" or dlc_tok[-1:] != b"]" or _DLC.fullmatch(dlc_tok[1:-1]) is None:
        raise ValueError("no [dlc]")
    dlc = int(dlc_tok[1:-1])
    if len(rest) > 1 and rest[1] == b"remote":
        raise _Skip("remote_frames")
    octets = rest[1 : 1 + dlc]
    if len(octets) != dlc or any(len(o) != 2 for o in octets):
        raise ValueError(f"expected {dlc} data bytes")
    can_id, ext = _ident(ident)
    _length(dlc, dlc > 8)  # candump prints an FD frame's length as [12]..[64]
    if iface is not None:
        _iface(iface)
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
        except (_Skip, _Reject):
            return True
        except (ValueError, UnicodeDecodeError):
            return False
        return True
    return False


class _General:
    """The lines the fast path of `read` does not take: every layout, every reason."""

    def __init__(self, source: str, health: ComponentHealth, bus_from_line: bool, accept: Callable[[float], bool],
                 reject: Callable[[str, str], None]) -> None:
        self.source = source
        self.health = health
        self.bus_from_line = bus_from_line
        self.accept = accept
        self.reject = reject
        self.untimed = False  # an untimed line was reported

    def fields(self, line: bytes, lineno: int) -> tuple[float | None, bytes | None, int, bool, bytes] | None:
        """`_parse` of the line, or None when it was counted instead (a frame without
        data, a value that cannot be true, not candump)."""
        try:
            return _parse(line.strip())
        except _Skip as skip:
            self.health.count(skip.counter)
        except _Reject as bad:
            self.reject(bad.reason, f"line {lineno}: {bad}")
        except (ValueError, UnicodeDecodeError) as exc:
            self.health.count("rejected.bad_line")
            self.health.error(f"line {lineno}: not a candump frame ({exc})")
        return None

    def record(self, line: bytes, lineno: int) -> RawRecord | None:
        if not _meaningful(line):
            return None
        fields = self.fields(line, lineno)
        if fields is None:
            return None
        t, iface, can_id, ext, data = fields
        if t is None:
            t = 0.0
            self.health.count("untimed")
            if not self.untimed:
                self.untimed = True
                self.health.error(f"line {lineno}: candump log without timestamps, frames stamped 0.0")
        elif not self.accept(t):
            self.reject(BAD_TIME, f"line {lineno}: time {line.strip()[1:].partition(b')')[0][:32]!r} cannot be true")
            return None
        bus = iface.decode("ascii") if self.bus_from_line and iface else self.source  # iface: checked ASCII
        meta: dict[str, Any] = {"id": can_id, "ext": ext}
        if b"##" in line:  # a CAN FD frame (`ID##<flags><data>`): the decoder allows 64 bytes
            meta["fd"] = True
        return RawRecord("can", bus, t, data, meta)


def read(
    stream: BinaryIO,
    source: str,
    health: ComponentHealth,
    *,
    bus_from_line: bool,
    limits: TimeLimits = DEFAULT_LIMITS,
) -> Iterator[RawRecord]:
    """RawRecords of a candump log in file order; bad lines are counted and skipped.

    With `bus_from_line` the record's source is the interface the line names (`can0`),
    so that several files of one bus share one decoder (a fast-packet message split
    across two files is reassembled); otherwise, or where the line names none, `source`.

    Times are judged by an `edged.timecheck.TimeWindow` from `limits`, from 0 on
    rather than 1980 (`candump -t z` logs count from zero): NaN, infinite, negative,
    exponent-written or implausibly late times are `rejected.bad_time`; identifiers
    that are not 1..8 hex digits `rejected.bad_id`, impossible data lengths
    `rejected.bad_length`, interface names that are not printable ASCII
    `rejected.bad_interface`.
    """
    accept = TimeWindow(limits, earliest=0.0).accept
    reject = rejecter(health)
    general = _General(source, health, bus_from_line, accept, reject)
    fast = _FAST.fullmatch
    buses: dict[bytes, str] = {}
    for lineno, line in numbered_lines(stream, reject):
        m = fast(line)
        if m is not None:
            # `candump -l`, the common case, in one match: every field is already of
            # its strict shape; only the identifier's range and the time remain.
            stamp, iface, ident, hexdata = m.groups()
            can_id = int(ident, 16)
            ext = len(ident) == 8
            t = float(stamp)
            if can_id < (_CAN_ERR_FLAG if ext else 0x800):
                if accept(t):  # once per line: a run of rejected times counts lines
                    bus = buses.get(iface) if bus_from_line else source
                    if bus is None:
                        bus = buses[iface] = iface.decode("ascii")
                    yield RawRecord("can", bus, t, bytes.fromhex(hexdata.decode("ascii")), {"id": can_id, "ext": ext})
                else:
                    reject(BAD_TIME, f"line {lineno}: time {stamp[:32]!r} cannot be true")
                continue
            # out of range or an error frame: the general path says which
        r = general.record(line, lineno)
        if r is not None:
            yield r
