"""The NMEA 0183 log reader for `edged replay` (entry point `nmea0183`, group `edged.logs`).

Light on purpose: the replay driver loads every reader to learn its priority, and
sniffs files with it; the framer (numpy) and the decoder are imported by `open`, for
an NMEA 0183 log only (`logfile.read_log`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord

from . import PROTOCOL

__all__ = ["Nmea0183Log", "NMEA0183", "sniff"]

#: Lines `sniff` judges at most (a head of 4 KiB holds about 50 sentences).
_SNIFF_LINES = 400
#: iKonvert's `!PDGY` lines carry NMEA 2000 without an NMEA 0183 checksum: a log of
#: them is the CAN input's (`edged_can.formats.ikonvert`), not ours.
_N2K_ENCAPSULATED = (b"!PDGY,",)
#: The shape of an NMEA 0183 line, valid or not: an optional TAG block or UNIX-time
#: prefix, `$` or `!`, an address of letters and digits, then a field or the checksum.
_SHAPE = re.compile(rb"(?:\\[^\\]*\\|[0-9]+(?:\.[0-9]*)?[ \t]+)?([$!][A-Z0-9]{3,10})(?:,|\*[0-9A-Fa-f]{2}$)")
_N2K_ADDRESSES = frozenset(p[:-1] for p in _N2K_ENCAPSULATED)


def sniff(head: bytes) -> bool:
    """True when most of the lines of `head` that are not comments are shaped like
    NMEA 0183 sentences (`$`/`!`, an address, fields; optionally a TAG block or time
    before). Their checksums are not judged here: a noisy stretch of bad checksums
    at the start of a good log is the reader's to count, not a reason to refuse the
    file. NMEA 2000 wrapped in 0183 framing counts against (another format)."""
    lines = head.replace(b"\r", b"\n").split(b"\n")
    if len(lines) > 1:
        lines.pop()  # maybe cut in the middle
    good = bad = 0
    match = _SHAPE.match
    for line in lines:
        line = line.strip()
        if not line or line[:1] == b"#":
            continue
        m = match(line)
        if m is None or m.group(1) in _N2K_ADDRESSES:
            bad += 1
        else:
            good += 1
        if good + bad >= _SNIFF_LINES:
            break
    return good > 0 and good >= bad


@dataclass(frozen=True)
class Nmea0183Log:
    """NMEA 0183 logs: plain lines, TAG blocks or a UNIX time before each sentence.

    Sniffed last (priority 90), after the CAN and gateway text formats, which all
    decline NMEA 0183 sentences: a file of `$PCDIN`/`$MXPGN` sentences (NMEA 2000
    wrapped in NMEA 0183) is this reader's, and its NMEA 2000 goes on to the CAN
    decoder as records of protocol "can" (the driver finds that decoder among the
    inputs, by protocol)."""

    name: str = "nmea0183"
    priority: int = 90
    protocol: str = PROTOCOL
    input: str | None = "nmea0183"

    def sniff(self, head: bytes) -> bool:
        return sniff(head)

    def open(
        self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        from .logfile import read_log

        return read_log(stream, source, health, options)


NMEA0183 = Nmea0183Log()
