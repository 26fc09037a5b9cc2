"""Replay: recorded logs through the very same decoders, workers and outputs.

Each file is recognised by content (the `sniff` of the log readers, entry point group
`edged.logs`, in their priority order), read by its reader's `open`, and the raw
records of all files are merged in time order. Every raw record is published (so
`--record` records it again) and decoded by the decoder of its protocol and source:
the `make_decoder` of the input plugin the reader names (`LogReader.input`), made
once and kept for the whole replay so that state (fast-packet reassembly, the date
of an NMEA log) carries across files.
Time is the data's: the replay clock follows the records. `speed` 0 runs as fast as
possible; N > 0 paces the records at N times real time.

Times that cannot be true are rejected by the readers (`rejected.bad_time`, window of
edged.timecheck, whose `TimeLimits` the replayer hands each reader in its options as
`time_limits`); the driver itself refuses any record whose time is not finite, is
negative or lies after the limits' `latest` (the one-day rule is the readers': it is
per log, and the files of one replay may be days apart), counting it in the health of
its source, so that no reader's mistake can move the clock there.

Pacing never waits long: when the next record is due more than `max_wait` seconds of
wall time ahead (default MAX_WAIT = 10 s: a gap of 1000 s in the log at `--speed 100`,
of 10 s at `--speed 1`), the gap is skipped with one warning and pacing resumes from
that record, so that a log with an hour's pause (or a stray late time) does not make
the replay sit idle.
"""

from __future__ import annotations

import asyncio
import heapq
import io
import logging
import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Awaitable, Callable, Iterator

from .clock import ReplayClock
from .health import ComponentHealth
from .plugin import Decoder, LogReader, ReplayOptions
from .records import HealthRecord, RawRecord
from .runtime import Runtime
from .logformats import CountingReader, detect, file_size
from .quietgc import QuietGC
from .timemerge import merge2
from .timecheck import BAD_TIME, DEFAULT_LIMITS, TimeLimits

log = logging.getLogger("edged.replay")

#: Records between two looks at the outputs' queues and the progress bar.
BATCH = 512
#: Seconds a replay waiting for a full worker waits at most before it looks again.
WORKER_WAIT = 0.05
#: Longest wall-time wait of the pacing (`speed` > 0); a longer gap is skipped.
MAX_WAIT = 10.0


#: Seconds a record may lie behind the replay's clock before its log counts as having
#: stepped back (merged files and sensors' latencies are well within it; the routers'
#: own reorder windows still judge what is late for each estimator).
STEP_BACK = 60.0


def utc_iso(t: float) -> str:
    """A data time as the summary and the log print it: ISO 8601, UTC, milliseconds."""
    try:
        return datetime.fromtimestamp(t, tz=timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")
    except (OverflowError, OSError, ValueError):
        return f"t={t!r}"


@dataclass
class ReplayStats:
    records: int = 0
    measurements: dict[tuple[str, str], int] = field(default_factory=dict)
    t_first: float | None = None
    t_last: float | None = None
    undecodable: dict[str, int] = field(default_factory=dict)
    #: records the driver refused for their time (the readers count theirs themselves)
    bad_time: int = 0
    #: gaps the pacing skipped instead of waiting (longer than `max_wait` at the speed)
    gaps_skipped: int = 0
    #: per source, where its time first stepped back by more than STEP_BACK s behind the
    #: replay's clock: (its record number from 1, the clock's time then, the record's)
    stepped_back: dict[str, tuple[int, float, float]] = field(default_factory=dict)
    #: per source, its records more than STEP_BACK s behind the replay's clock: they
    #: reach the outputs but no estimator (the routers count them `late`)
    behind: dict[str, int] = field(default_factory=dict)


class Replayer:
    """Feeds files through a replay-mode Runtime."""

    def __init__(
        self,
        runtime: Runtime,
        paths: list[Path],
        *,
        speed: float = 0.0,
        date: str | None = None,
        progress: Callable[[int, int], None] | None = None,
        time_limits: TimeLimits = DEFAULT_LIMITS,
        max_wait: float = MAX_WAIT,
        sleep: Callable[[float], Awaitable[Any]] = asyncio.sleep,
    ) -> None:
        if not isinstance(runtime.clock, ReplayClock):
            raise TypeError("replay needs a ReplayClock")
        self.rt = runtime
        self.clock: ReplayClock = runtime.clock
        self.paths = paths
        self.speed = speed
        self.date = date
        self.progress = progress
        self.time_limits = time_limits
        self.max_wait = max_wait
        self._sleep = sleep
        self.stats = ReplayStats()
        self._decoders: dict[tuple[str, str], Decoder | None] = {}
        #: protocol -> type name of the input whose decoder reads it: the inputs the
        #: readers of the files name (`_open`), so that a replay does not import every
        #: input plugin (and its decoding stack); all inputs' `protocol` only for a
        #: protocol none of those readers names (the records of an MCAP recording).
        self._inputs: dict[str, str] = {}
        self._protocols: dict[str, str] | None = None
        self._streams: list[CountingReader] = []
        self.total_bytes = sum(file_size(p) for p in paths)
        #: Bytes read from files already closed (the progress bar's count).
        self._bytes_done = 0
        self._readers: dict[Path, tuple[str, LogReader]] = {}

    def _health(self, source: str, type_: str) -> ComponentHealth:
        return self.rt.health.component(source, "input", type_)

    def _reader(self, path: Path) -> tuple[str, LogReader]:
        found = self._readers.get(path)
        if found is None:
            found = self._readers[path] = detect(path, self.rt.registry)
        return found

    def _open(self, path: Path) -> Iterator[RawRecord]:
        return self._open_stream(path)[0]

    def _open_stream(self, path: Path) -> tuple[Iterator[RawRecord], CountingReader]:
        name, reader = self._reader(path)
        input_type = getattr(reader, "input", None)
        protocol = getattr(reader, "protocol", "")
        if protocol and input_type:
            self._inputs.setdefault(protocol, input_type)
        source = path.stem
        in_cfg = self.rt.config.inputs.get(source)
        f = CountingReader(open(path, "rb"), source)  # closed at its end or in run()
        self._streams.append(f)
        # The file's health component has the type of the input that decodes it
        # ("can" for every CAN and gateway format), or the reader's name ("mcap").
        health = self._health(source, input_type or name)
        opts = ReplayOptions(date=self.date, config=in_cfg, path=path)
        opts.time_limits = self.time_limits
        return reader.open(io.BufferedReader(f, 1 << 16), source, health, opts), f

    def _first_time(self, path: Path) -> float:
        """The time of the file's first record (-inf when it has none, or one that is
        not a number): read by a reader of its own into a health that is thrown away,
        so that the replay's counts and log see the file once."""
        name, reader = self._reader(path)
        opts = ReplayOptions(date=self.date, config=self.rt.config.inputs.get(path.stem), path=path)
        opts.time_limits = self.time_limits
        health = _UnseenHealth(path.stem, "input", name, self.clock)
        with open(path, "rb") as f:
            records = reader.open(io.BufferedReader(f, 1 << 16), path.stem, health, opts)
            try:
                first = next(iter(records), None)
            finally:
                close = getattr(records, "close", None)
                if close is not None:
                    close()
        t = first.t if first is not None else _NONE
        return t if t == t else _NONE

    async def _in_start_order(self) -> Iterator[RawRecord]:
        """Many files, each opened when the replay reaches its first record and
        closed at its end: what is held (a descriptor, buffers, a reader's state) is
        that of the files whose times overlap, not of every file named. A thousand
        one-minute logs held 1.37 GB and 1,010 descriptors when all were open at once
        (issue 32). Each file's first time is read first, with a look at the event
        loop every few files, so that a stop signal is heard while thousands are read."""
        starts: list[tuple[float, int, Path]] = []
        for i, path in enumerate(self.paths):
            starts.append((self._first_time(path), i, path))
            if i % 16 == 15:
                await asyncio.sleep(0)
        starts.sort(key=lambda s: (s[0], s[1]))
        return self._lazy_merge(starts)

    def _lazy_merge(self, starts: list[tuple[float, int, Path]]) -> Iterator[RawRecord]:
        """The records of the files in time order, ties to the file named first (as
        `heapq.merge` orders them); a record whose time is not a number goes out at
        once. A file is opened when the earliest record held is not before its first
        time, and closed (its input left out of the health snapshot) at its end."""
        heap: list[tuple[float, int, RawRecord, Iterator[RawRecord], CountingReader, Path]] = []
        push, replace, pop = heapq.heappush, heapq.heapreplace, heapq.heappop
        w = 0
        while True:
            while w < len(starts) and (not heap or starts[w][0] <= heap[0][0]):
                _t0, i, path = starts[w]
                w += 1
                it, stream = self._open_stream(path)
                rec = next(it, None)
                if rec is None:
                    self._closed(stream, path)
                    continue
                t = rec.t
                push(heap, (t if t == t else _NONE, i, rec, it, stream, path))
            if not heap:
                return
            _t, i, rec, it, stream, path = heap[0]
            yield rec
            nxt = next(it, None)
            if nxt is None:
                pop(heap)
                self._closed(stream, path)
            else:
                t = nxt.t
                replace(heap, (t if t == t else _NONE, i, nxt, it, stream, path))

    def _closed(self, stream: CountingReader, path: Path) -> None:
        """A file read to its end: closed, its bytes counted, its input retired from
        the health snapshot when no other file of that source is still open (its
        counters stay, for the summary)."""
        self._bytes_done += stream.count
        stream.close()
        self._streams.remove(stream)
        source = path.stem
        if not any(s.source == source for s in self._streams):
            self.rt.health.retire(source, "input")

    def _input_type(self, protocol: str) -> str | None:
        """The type name of the input that decodes `protocol`: the one the readers of
        the files name, else the first input (in name order) of that `protocol`."""
        name = self._inputs.get(protocol)
        if name is None:
            if self._protocols is None:
                self._protocols = {}
                for n, c in self.rt.registry.iter("inputs"):
                    self._protocols.setdefault(getattr(c, "protocol", ""), n)
            name = self._protocols.get(protocol)
        return name

    def _decoder(self, protocol: str, source: str) -> Decoder | None:
        key = (protocol, source)
        if key in self._decoders:
            return self._decoders[key]
        dec = None
        type_name = self._input_type(protocol)
        cls = None
        if type_name is not None:
            try:
                cls = self.rt.registry.get("inputs", type_name)
            except Exception as exc:  # a reader naming an input that is not installed
                log.warning("no decoder for %s records of %s: input %s: %s", protocol, source, type_name, exc)
        if cls is not None:
            cfg = self.rt.config.inputs.get(source)
            if cfg is not None and getattr(cfg, "type", None) != type_name:
                cfg = None
            try:
                dec = cls.make_decoder(source, cfg, self._health(source, protocol), self.rt.own_marks)
            except NotImplementedError:
                dec = None
        self._decoders[key] = dec
        return dec

    async def run(self) -> ReplayStats:
        """Replay every record; returns the counts for the summary."""
        merged = await self._records()
        # Look at the queues often enough that none fills between two looks, however
        # small it is configured (a raw record makes a few measurements): the replay
        # then never drops, whatever its speed.
        batch = max(1, min([BATCH, *(w.sub.queue.maxsize // 8 for w in self.rt.workers)]))
        publish, clock, stats = self.rt.router.publish, self.clock, self.stats
        meas = stats.measurements
        interval = self.rt.config.edged.health_interval
        next_tick = math.inf
        loop = asyncio.get_running_loop()
        self._wall0 = loop.time()
        self._next_flush = self._wall0 + interval
        t0: float | None = None
        n = 0
        top = self.time_limits.latest
        speed = self.speed
        decoders = self._decoders
        quiet_gc = QuietGC()
        seen: dict[str, int] = {}  # records per source so far (to name where a step is)
        try:
            for raw in merged:
                t = raw.t
                if not 0.0 <= t <= top:  # NaN fails, ±inf fails
                    self._refuse(raw)
                    continue
                if t0 is None:
                    t0 = stats.t_first = t
                    next_tick = t + interval
                    # after the outputs are linked, at the first record: data flows now
                    log.info("event=replay-started inputs=%d speed=%g", len(self.paths), speed)
                if t < clock.now() - STEP_BACK:
                    self._behind(raw, clock.now(), seen.get(raw.source, 0) + 1)
                seen[raw.source] = seen.get(raw.source, 0) + 1
                clock.advance_to(t)
                if speed > 0:
                    await self._pace(raw, t - t0, loop)
                publish(raw)
                dec = decoders.get((raw.protocol, raw.source), _UNKNOWN)
                if dec is _UNKNOWN:
                    dec = self._decoder(raw.protocol, raw.source)
                if dec is None:
                    stats.undecodable[raw.protocol] = stats.undecodable.get(raw.protocol, 0) + 1
                else:
                    for m in dec.decode(raw):
                        key = (m.source, m.kind)
                        meas[key] = meas.get(key, 0) + 1
                        publish(m)
                n += 1
                if clock.now() >= next_tick:
                    next_tick = self._tick(loop, interval)
                if n % batch == 0:
                    await self._yield()
            await self._finish(n, t0 is not None)
        finally:
            quiet_gc.restore()
            for s in self._streams:
                s.close()
        return stats

    async def _records(self) -> Iterator[RawRecord]:
        """The records of every log in time order, once every output had its bounded
        chance to link (a publisher not linked yet would lose the voyage's start:
        counted, but lost)."""
        await self.rt.outputs_ready()
        if len(self.paths) > 2:
            return await self._in_start_order()
        iters = [self._open(p) for p in self.paths]
        return merge2(*iters) if len(iters) == 2 else iters[0]

    async def _pace(self, raw: RawRecord, elapsed: float, loop: asyncio.AbstractEventLoop) -> None:
        """`--speed N`: wait until `raw` is due, `elapsed` data seconds after the first
        record; a gap longer than `max_wait` of wall time is skipped, and said."""
        delay = self._wall0 + elapsed / self.speed - loop.time()
        if delay > self.max_wait:
            self.stats.gaps_skipped += 1
            log.warning(
                "replay: %.1f s without data before %s at t=%.3f "
                "(%.1f s of wall time at --speed %g): skipped, not waited for",
                delay * self.speed, raw.source, raw.t, delay, self.speed,
            )
            self._wall0 -= delay  # this record is due now; pacing goes on from it
        elif delay > 0:
            await self._sleep(delay)

    def _tick(self, loop: asyncio.AbstractEventLoop, interval: float) -> float:
        """Health in data time (the same log gives the same health records); the
        outputs' flush in wall time (fsync per second, not per record). Returns the
        data time of the next tick."""
        wall = loop.time()
        flush = wall >= self._next_flush
        self.rt.tick(flush=flush)
        if flush:
            self._next_flush = wall + interval
        return self.clock.now() + interval

    async def _finish(self, n: int, any_record: bool) -> None:
        """The end of the logs: every record stepped by the estimators, however long
        that takes, then the last health."""
        self.stats.records = n
        self.stats.t_last = self.clock.now() if any_record else None
        await self.rt.finish_workers(patient=True)
        snap = self.rt.health_snapshot()
        self.rt.router.publish(HealthRecord(snap["t"], snap))
        await self._yield(final=True)

    def _behind(self, raw: RawRecord, now: float, index: int) -> None:
        """A record far behind the replay's clock: its log's time stepped back (two
        logs in one file, a receiver's clock set back an hour). The clock cannot go
        back with it (every estimator has moved on), so what follows is late for them:
        said once per source with where and how far, counted, and in the summary, not
        left to look like a short voyage. Real logs do it (canboat's can0-1: 431 frames
        stamped two weeks early mid-log; dirona: 61 s back once), so it is the log's
        own doing, not a failure of the replay: the exit code stays 0."""
        stats = self.stats
        stats.behind[raw.source] = stats.behind.get(raw.source, 0) + 1
        if raw.source not in stats.stepped_back:
            stats.stepped_back[raw.source] = (index, now, raw.t)
            log.warning(
                "replay: the time of %s steps back %.1f s at its record %d (to %s, after %s): "
                "its records from there are behind the replay's clock and reach no estimator",
                raw.source, now - raw.t, index, utc_iso(raw.t), utc_iso(now),
            )

    def _refuse(self, raw: RawRecord) -> None:
        """A record whose time no reader should have let through: counted, logged."""
        self.stats.bad_time += 1
        h = self._health(raw.source, raw.protocol)
        h.count("rejected." + BAD_TIME)
        h.error("records whose time is not finite, negative or after the time limits' latest: refused")

    async def _yield(self, final: bool = False) -> None:
        """Let the workers and outputs work; wait while their queues are more than
        half full (a replay never drops what a live daemon would have kept)."""
        if self.progress is not None:
            self.progress(self._bytes_done + sum(s.count for s in self._streams), self.total_bytes)
        await asyncio.sleep(0)
        rt = self.rt
        wlimit = min((w.sub.queue.maxsize // 2 for w in rt.workers), default=0)
        while rt.workers and rt.worker_backlog() > wlimit:
            # until each full worker has taken its next batch (in its own process, in
            # its own time: nothing here holds the GIL the process host's threads need)
            await rt.worker_progress(wlimit, WORKER_WAIT)
        limit = 0 if final else min((o.sub.queue.maxsize // 2 for o in rt.outputs), default=0)
        while rt.outputs and (rt.output_backlog() > limit or rt.outputs_blocked()):
            await rt.output_progress(limit, WORKER_WAIT)


#: The sort key of a file without a first record, or of a record whose time is not a
#: number: before every other (opened, and sent on, at once).
_NONE = float("-inf")


class _UnseenHealth(ComponentHealth):
    """The health of a file read only for its first time: nothing it counts or logs
    is seen (the replay reads the file again, and counts that)."""

    __slots__ = ()

    def error(self, message: str) -> None:
        self.last_error = message

    def set_state(self, state: str, reason: str | None = None) -> None:
        self.state = state

    def set_problems(self, problems: list[str]) -> None:
        self.problems = [str(p) for p in problems]


_UNKNOWN = object()  # no decoder looked up yet for a (protocol, source)
