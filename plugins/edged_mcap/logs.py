"""The MCAP log reader for `edged replay` (entry point `mcap`, group `edged.logs`).

Light on purpose: the replay driver loads every reader to learn its priority, and
sniffs every file with this one first (a magic, priority 10); the mcap library is
imported by `open`, for a recording only (`rawreader.read_raw`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import BinaryIO, Iterator

from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import RawRecord

__all__ = ["MAGIC", "McapLog", "MCAP"]

#: The MCAP file magic (the specification's; `reading.MAGIC` is the same bytes).
MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True)
class McapLog:
    """MCAP recordings (ours, or any with `/raw/...` channels of raw records).

    A recording holds records of many protocols and sources (`protocol` ""): each is
    decoded by the input whose `protocol` is its own."""

    name: str = "mcap"
    priority: int = 10
    protocol: str = ""
    input: str | None = None

    def sniff(self, head: bytes) -> bool:
        return head.startswith(MAGIC)

    def open(
        self, stream: BinaryIO, source: str, health: ComponentHealth, options: ReplayOptions
    ) -> Iterator[RawRecord]:
        """The recorded raw channels as RawRecords, exactly as they were recorded."""
        from edged.timecheck import limits_of

        from .rawreader import read_raw

        return read_raw(stream, health, options.path or source, limits_of(options))


MCAP = McapLog()
