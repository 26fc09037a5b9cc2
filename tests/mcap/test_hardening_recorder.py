"""Hardening of the recorder (issue 10): counts of what reached the file, a full disk
that leaves no empty files and backs off, free space measured when it matters, and
memory that stays flat however long the recording (files rotate at a chunk bound)."""

from __future__ import annotations

import asyncio
import errno
import io
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from edged.clock import ManualClock
from edged.health import ComponentHealth
from edged.plugin import PluginContext
from edged.records import RawRecord
from edged_mcap.config import GIB
from edged_mcap.mcapfile import McapFile
from edged_mcap.placement import numbered
from edged_mcap.recorder import RETRY_MAX_SECONDS, McapRecorder
from edged_mcap.recovery import recover

T0 = 1_732_350_000.0


def _raw(i: int, size: int = 60) -> RawRecord:
    return RawRecord("nmea0183", "g", T0 + i * 0.01, b"$" + bytes([65 + i % 26]) * size + b"*00", {"n": i})


def _messages(path: Path) -> list[int]:
    with open(path, "rb") as f:
        return [m.log_time for _, _, m in make_reader(f).iter_messages()]


class Disk:
    """Real files on a disk that fills up when the test says so (or after `budget` bytes)."""

    def __init__(self) -> None:
        self.full = False
        self.budget: int | None = None  # bytes the disk still takes, None: unlimited
        self.opened: list[Path] = []

    def __call__(self, path: Path, mode: str) -> io.FileIO:
        disk = self
        self.opened.append(path)

        class _File(io.FileIO):
            def write(self, b) -> int:  # type: ignore[override]
                if disk.full:
                    raise OSError(errno.ENOSPC, "No space left on device")
                if disk.budget is not None:
                    if disk.budget <= 0:
                        raise OSError(errno.ENOSPC, "No space left on device")
                    b = bytes(b)[: disk.budget]  # a short write, then the next one fails
                    disk.budget -= len(b)
                return super().write(b)

        return _File(path, mode)


class FreeSpace:
    def __init__(self, free: int) -> None:
        self.free = free
        self.asked = 0

    def __call__(self, path: Path) -> int:
        self.asked += 1
        return self.free


def _mcaps(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir() if p.suffix == ".mcap") if d.exists() else []


# -- 1. counts that say what reached the file --------------------------------------------
def test_recorded_counts_only_what_reached_the_file(make_rig, tmp_path):
    disk = Disk()
    path = tmp_path / "x.mcap"
    rig = make_rig(path=str(path), opener=disk)
    rig.open()
    rig.rec.write([_raw(i) for i in range(40)])
    rig.rec.flush()
    assert rig.health.counters["recorded"] == 40
    disk.full = True
    rig.rec.write([_raw(i) for i in range(40, 70)])  # into the open chunk: not yet in the file
    assert rig.health.counters["recorded"] == 40
    rig.rec.flush()  # the chunk cannot be written: those 30 never reach the file
    assert rig.health.state == "disk_full"
    rig.rec.write([_raw(70), _raw(71)])  # stopped
    rig.close()
    c = rig.health.counters
    assert c["recorded"] == 40
    assert c["dropped.disk_full"] == 32
    assert len(_messages(recover(path).output)) == c["recorded"]


def test_recorded_equals_the_file_s_message_count_after_close(make_rig, tmp_path, sample):
    rig = make_rig(path=str(tmp_path / "out.mcap"), chunk_kib=4)
    rig.open()
    recs = sample(seconds=5)
    for i in range(0, len(recs), 37):
        rig.rec.write(recs[i : i + 37])
        if i % 5 == 0:
            rig.rec.flush()
    rig.close()
    with open(tmp_path / "out.mcap", "rb") as f:
        n = make_reader(f).get_summary().statistics.message_count
    assert rig.health.counters["recorded"] == n > len(recs)
    assert not any(k.startswith("dropped.") for k in rig.health.counters)


# -- 2. a full disk: no empty files, backoff, free space measured ------------------------
def test_no_file_is_created_without_room_for_one(make_rig, tmp_path):
    d = tmp_path / "rec"
    free = FreeSpace(0)
    rig = make_rig(directory=str(d), min_free_gib=0, free_bytes=free)
    rig.open()
    assert rig.health.state == "disk_full"
    assert "bytes free" in rig.health.last_error
    assert rig.health.info["disk_free_bytes"] == 0
    for _ in range(360):  # an hour of retries
        rig.rec.write([_raw(0)])
        rig.clock.step(10)
        rig.rec.flush()
    assert _mcaps(d) == []
    assert rig.health.counters["stops.disk_full"] == 1  # once per change of state
    free.free = 10 * GIB
    rig.clock.step(10)
    rig.rec.flush()
    assert rig.health.state == "recording"
    assert rig.health.info["disk_free_bytes"] == 10 * GIB
    rig.close()


def test_a_header_that_cannot_be_written_leaves_no_file_and_retries_back_off(make_rig, tmp_path):
    """The disk says it has room (quota, reserved blocks) but every write fails."""
    d = tmp_path / "rec"
    disk = Disk()
    disk.full = True
    rig = make_rig(directory=str(d), min_free_gib=0, free_bytes=FreeSpace(50 * GIB), opener=disk, retry_seconds=10)
    rig.open()
    assert rig.health.state == "disk_full"
    assert _mcaps(d) == []
    attempts_at: list[float] = [0.0]
    for s in range(1, 3601):  # an hour, flushed every second
        rig.clock.step(1)
        n = len(disk.opened)
        rig.rec.flush()
        if len(disk.opened) > n:
            attempts_at.append(float(s))
        assert _mcaps(d) == []
    gaps = [b - a for a, b in zip(attempts_at, attempts_at[1:])]
    assert gaps[:5] == [10, 20, 40, 80, 160]
    assert set(gaps[5:]) == {RETRY_MAX_SECONDS}
    assert len(attempts_at) < 20  # not 360 an hour
    assert rig.health.counters["stops.disk_full"] == 1
    assert rig.health.counters["files_removed_empty"] == len(attempts_at)
    # Room again: the next attempt records, and the backoff starts afresh after data.
    disk.full = False
    rig.clock.step(RETRY_MAX_SECONDS)
    rig.rec.flush()
    assert rig.health.state == "recording"
    rig.rec.write([_raw(1)])
    rig.rec.flush()
    disk.full = True
    rig.rec.write([_raw(2)])
    rig.rec.flush()
    assert rig.health.state == "disk_full"
    disk.full = False
    rig.clock.step(10)
    rig.rec.flush()
    assert rig.health.state == "recording"  # 10 s again, not 300
    rig.rec.write([_raw(3)])
    rig.close()
    first, second = _mcaps(d)  # the file cut by the full disk stays (it holds data) ...
    assert len(_messages(recover(d / first).output)) == 1
    assert len(_messages(d / second)) == 1  # ... and the next one is a finished file


@pytest.mark.parametrize("budget", [0, 100], ids=["header-only", "cut-chunk"])
def test_a_file_that_got_no_complete_chunk_is_removed(make_rig, tmp_path, budget):
    d = tmp_path / "rec"
    disk = Disk()
    rig = make_rig(directory=str(d), opener=disk, free_bytes=FreeSpace(50 * GIB), compression="none")
    rig.open()
    assert len(_mcaps(d)) == 1  # the header is written at once
    disk.budget = budget
    rig.rec.write([_raw(i) for i in range(20)])
    rig.rec.flush()
    assert rig.health.state == "disk_full"
    assert _mcaps(d) == []
    assert rig.rec.status()["files"] == 0
    assert rig.health.counters["dropped.disk_full"] == 20
    rig.close()


def test_a_file_with_data_stays_for_recover(make_rig, tmp_path):
    d = tmp_path / "rec"
    disk = Disk()
    rig = make_rig(directory=str(d), opener=disk, free_bytes=FreeSpace(50 * GIB))
    rig.open()
    rig.rec.write([_raw(i) for i in range(20)])
    rig.rec.flush()
    disk.full = True
    rig.rec.write([_raw(i) for i in range(20, 30)])
    rig.rec.flush()
    assert rig.health.state == "disk_full"
    (name,) = _mcaps(d)
    assert len(_messages(recover(d / name).output)) == 20
    rig.close()


def test_an_exact_file_that_got_nothing_is_retried(make_rig, tmp_path):
    """`replay --record OUT.mcap` on a full disk: nothing to truncate, so it retries."""
    disk = Disk()
    disk.full = True
    path = tmp_path / "out.mcap"
    rig = make_rig(path=str(path), opener=disk, free_bytes=FreeSpace(50 * GIB), retry_seconds=1)
    rig.open()
    assert rig.health.state == "disk_full"
    assert not path.exists()
    disk.full = False
    rig.clock.step(1)
    rig.rec.flush()
    assert rig.health.state == "recording"
    rig.rec.write([_raw(0)])
    rig.close()
    assert len(_messages(path)) == 1


def test_free_space_is_measured_at_every_flush(make_rig, tmp_path):
    free = FreeSpace(40 * GIB)
    rig = make_rig(directory=str(tmp_path / "rec"), free_bytes=free, retry_seconds=10)
    rig.open()
    assert rig.health.info["disk_free_bytes"] == 40 * GIB
    for k in range(1, 6):
        free.free = (40 - k) * GIB
        rig.clock.step(1)  # one flush period, well within retry_seconds
        rig.rec.write([_raw(k)])
        rig.rec.flush()
        assert rig.health.info["disk_free_bytes"] == (40 - k) * GIB
    free.free = GIB // 4
    rig.clock.step(1)
    rig.rec.flush()
    assert rig.health.state == "disk_low"  # the floor is seen at the next flush, not 10 s later
    assert rig.health.info["disk_free_bytes"] == GIB // 4
    rig.close()


# -- 3. memory that does not grow with the voyage -----------------------------------------
def _recorder(tmp_path: Path, max_chunks: int, **cfg: Any) -> tuple[McapRecorder, ManualClock, ComponentHealth]:
    clock = ManualClock(T0)
    health = ComponentHealth("rec", "output", "mcap", clock)
    ctx = PluginContext("rec", clock, health, lambda r: None, vessel_id="ship1", options={})
    config = McapRecorder.Config.model_validate({"type": "mcap", "compression": "none", "chunk_kib": 1, **cfg})
    return McapRecorder(config, ctx, max_chunks=max_chunks), clock, health


def test_an_exact_recording_rotates_into_numbered_files_at_the_chunk_bound(tmp_path):
    out = tmp_path / "OUT.mcap"
    rec, clock, health = _recorder(tmp_path, 8, path=str(out))
    asyncio.run(rec.open())
    held: list[int] = []
    n = 3000
    for i in range(n):
        rec.write([_raw(i)])
        if i % 50 == 0:
            rec.flush()
        assert rec._file is not None
        held.append(rec._file.index_entries)
    asyncio.run(rec.close())
    assert max(held) <= 8  # the Writer's in-memory index stays bounded
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names[0] == "OUT.001.mcap" and "OUT.mcap" in names and len(names) > 5
    assert names == sorted(["OUT.mcap", *(numbered(out, k).name for k in range(1, len(names)))])
    total = 0
    for p in [out, *(numbered(out, k) for k in range(1, len(names)))]:
        with open(p, "rb") as f:
            summary = make_reader(f).get_summary()  # every file is finished, with its summary
        assert summary is not None and 0 < len(summary.chunk_indexes) <= 8
        total += len(_messages(p))
    assert total == n == health.counters["recorded"]
    assert health.counters["rotations.index"] == len(names) - 1
    # Data time runs on from one file into the next.
    firsts = [_messages(numbered(out, k))[0] for k in range(len(names))]
    assert firsts == sorted(firsts)


def test_directory_recordings_also_rotate_at_the_chunk_bound(tmp_path):
    d = tmp_path / "rec"
    rec, clock, health = _recorder(tmp_path, 5, directory=str(d), rotate_bytes=None, rotate_seconds=None)
    asyncio.run(rec.open())
    for i in range(1000):
        rec.write([_raw(i)])
    asyncio.run(rec.close())
    files = _mcaps(d)
    assert len(files) >= 3 and health.counters["rotations.index"] == len(files) - 1
    assert sum(len(_messages(d / n)) for n in files) == 1000


def test_index_entries_are_the_writer_s_chunk_indexes(tmp_path):
    path = tmp_path / "a.mcap"
    f = McapFile(open(path, "wb"), path, compression="zstd", chunk_size=1024, library="t", metadata={})
    f.start()
    for i in range(400):
        f.add("/raw/x", "edged.raw.nmea0183", b'{"line": "' + b"x" * 50 + b'"}', i, i)
    held = f.index_entries
    f.finish()
    with open(path, "rb") as fh:
        assert len(make_reader(fh).get_summary().chunk_indexes) in (held, held + 1)  # + the chunk open at finish
    assert held > 10


def test_backoff_stays_at_its_cap_through_weeks_of_failures(make_rig, tmp_path):
    disk = Disk()
    disk.full = True
    rig = make_rig(directory=str(tmp_path / "rec"), min_free_gib=0, free_bytes=FreeSpace(GIB), opener=disk)
    rig.open()
    for _ in range(1200):  # 100 hours at the cap: 2 ** 1200 would overflow a float
        rig.clock.step(RETRY_MAX_SECONDS)
        rig.rec.flush()
    assert rig.health.state == "disk_full"
    assert 1100 < len(disk.opened) <= 1201
    assert _mcaps(tmp_path / "rec") == []
    rig.close()


def _writer_bytes(packed: bool, messages: list[tuple[int, int, bytes]], flush_every: int, sink: Any = None) -> bytes:
    from mcap.writer import CompressionType, Writer

    from edged_mcap.fastmessages import FastMessages, PackedChunkIndexes

    out = sink if sink is not None else io.BytesIO()
    w = Writer(out, chunk_size=1024, compression=CompressionType.ZSTD)
    w.start(profile="", library="test")
    if packed:
        assert PackedChunkIndexes.attach(w), "the mcap Writer's chunk index list changed: update edged_mcap.fastmessages"
    sid = w.register_schema("s", "jsonschema", b"{}")
    channels = [w.register_channel(f"/c{i}", "json", sid) for i in range(14)]
    fm = FastMessages.attach(w)
    assert fm is not None
    for i, (ch, log, data) in enumerate(messages):
        fm.add(channels[ch], log, data, log)
        if (i + 1) % flush_every == 0:
            w.flush()
    w.finish()
    return out.getvalue() if sink is None else b""


def test_packed_chunk_indexes_give_the_same_file_byte_for_byte():
    import random

    rnd = random.Random(3)
    t0 = 1_732_350_000_000_000_000
    messages = [(rnd.randrange(14), t0 + i * 1_000_000, rnd.randbytes(rnd.randrange(1, 200))) for i in range(5000)]
    packed = _writer_bytes(True, messages, flush_every=333)
    assert packed == _writer_bytes(False, messages, flush_every=333)
    summary = make_reader(io.BytesIO(packed)).get_summary()
    assert len(summary.chunk_indexes) > 100
    assert sum(1 for _ in make_reader(io.BytesIO(packed)).iter_messages()) == 5000


def test_a_chunk_held_in_memory_costs_a_few_hundred_bytes_not_1_4_kb(tmp_path):
    import tracemalloc

    from mcap.writer import CompressionType, Writer

    from edged_mcap.fastmessages import FastMessages, PackedChunkIndexes

    def per_chunk(packed: bool) -> float:
        with open(tmp_path / f"{packed}.mcap", "wb") as sink:
            w = Writer(sink, chunk_size=1024, compression=CompressionType.NONE)
            w.start()
            if packed:
                PackedChunkIndexes.attach(w)
            sid = w.register_schema("s", "jsonschema", b"{}")
            channels = [w.register_channel(f"/c{i}", "json", sid) for i in range(14)]
            fm = FastMessages.attach(w)
            assert fm is not None
            tracemalloc.start()
            try:
                base = tracemalloc.get_traced_memory()[0]
                for i in range(1000 * 17):
                    fm.add(channels[i % 14], i, b"x" * 60, i)
                grown = tracemalloc.get_traced_memory()[0] - base
            finally:
                tracemalloc.stop()
            n = len(getattr(w, "_Writer__chunk_indices"))
            w.finish()
        return grown / n

    assert per_chunk(False) > 1000  # the library's ChunkIndex objects
    assert per_chunk(True) < 300


def test_a_recording_onto_something_that_is_not_a_regular_file_is_never_removed(tmp_path):
    """`--record /dev/full` once deleted the device: only regular files of ours go."""
    import os

    from edged_mcap.mcapfile import McapFile

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    fd = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)  # read-write: opening does not wait
    stream = os.fdopen(fd, "wb", buffering=0)
    f = McapFile(stream, fifo, compression="none", chunk_size=1024, library="t", metadata={})
    assert f.remove_if_empty(header_only=False) is False
    assert fifo.exists() and not fifo.is_file()
    stream.close()
