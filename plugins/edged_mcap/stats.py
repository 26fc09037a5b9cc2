"""What a recording holds: per channel counts, rates, time span and largest gap."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mcap.records import Channel, Message, Metadata, Schema

from .reading import ReadReport, iter_records

__all__ = ["ChannelStats", "FileStats", "file_stats"]


@dataclass
class ChannelStats:
    topic: str
    schema: str
    count: int = 0
    first_ns: int | None = None
    last_ns: int | None = None
    #: Largest step between consecutive messages (log time, file order) and where it began.
    max_gap_ns: int = 0
    max_gap_at_ns: int | None = None
    #: Messages whose log time is earlier than the one before (out of order).
    backwards: int = 0
    _prev_ns: int | None = None

    def add(self, log_ns: int) -> None:
        self.count += 1
        if self.first_ns is None or log_ns < self.first_ns:
            self.first_ns = log_ns
        if self.last_ns is None or log_ns > self.last_ns:
            self.last_ns = log_ns
        prev = self._prev_ns
        if prev is not None:
            gap = log_ns - prev
            if gap < 0:
                self.backwards += 1
            elif gap > self.max_gap_ns:
                self.max_gap_ns = gap
                self.max_gap_at_ns = prev
        self._prev_ns = log_ns

    @property
    def span_s(self) -> float:
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        return (self.last_ns - self.first_ns) / 1e9

    @property
    def rate_hz(self) -> float | None:
        """Mean message rate; None with fewer than two messages or no time span."""
        span = self.span_s
        return (self.count - 1) / span if self.count > 1 and span > 0 else None


@dataclass
class FileStats:
    path: Path
    size: int
    report: ReadReport
    channels: dict[int, ChannelStats] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)

    @property
    def messages(self) -> int:
        return sum(c.count for c in self.channels.values())

    @property
    def first_ns(self) -> int | None:
        firsts = [c.first_ns for c in self.channels.values() if c.first_ns is not None]
        return min(firsts) if firsts else None

    @property
    def last_ns(self) -> int | None:
        lasts = [c.last_ns for c in self.channels.values() if c.last_ns is not None]
        return max(lasts) if lasts else None


def file_stats(path: Path) -> FileStats:
    """Read the whole file (finished or not) and gather its statistics.

    Raises McapError when `path` is not MCAP, OSError when it cannot be read.
    """
    report = ReadReport()
    stats = FileStats(path, path.stat().st_size, report)
    schemas: dict[int, str] = {}
    chans = stats.channels
    with open(path, "rb") as f:
        for rec in iter_records(f, report):
            if isinstance(rec, Message):
                c = chans.get(rec.channel_id)
                if c is None:
                    report.orphans += 1
                else:
                    c.add(rec.log_time)
            elif isinstance(rec, Channel):
                if rec.id not in chans:
                    chans[rec.id] = ChannelStats(rec.topic, schemas.get(rec.schema_id, ""))
            elif isinstance(rec, Schema):
                schemas[rec.id] = rec.name
            elif isinstance(rec, Metadata):
                stats.metadata[rec.name] = dict(rec.metadata)
    return stats
