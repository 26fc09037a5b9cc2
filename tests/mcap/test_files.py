"""Rotation, retention, the free-disk floor and write errors: recording stops, never the daemon."""

from __future__ import annotations

import errno
import io
from pathlib import Path

import pytest
from mcap.reader import make_reader

from edged.records import RawRecord
from edged_mcap.config import GIB
from edged_mcap.files import prune, recordings


def _raw(i: int, size: int = 60) -> RawRecord:
    return RawRecord("nmea0183", "g", 1_732_350_000.0 + i * 0.01, b"$" + b"A" * size + b"*00", {"n": i})


def _messages(path: Path) -> list[int]:
    with open(path, "rb") as f:
        return [m.log_time for _, _, m in make_reader(f).iter_messages()]


def _names(d: Path) -> list[str]:
    return [r.path.name for r in recordings(d)]


def test_directory_mode_names_files_by_utc_start(make_rig, tmp_path):
    rig = make_rig(directory=str(tmp_path / "rec"))
    rig.open()
    rig.rec.write([_raw(0)])
    rig.close()
    assert _names(tmp_path / "rec") == ["edged-20241123T082000Z.mcap"]  # T0 = 1732350000


def test_rotation_by_size_keeps_every_message(make_rig, tmp_path):
    d = tmp_path / "rec"
    rig = make_rig(directory=str(d), rotate_bytes=4096, chunk_kib=1, compression="none")
    rig.open()
    for i in range(300):
        rig.rec.write([_raw(i)])
        rig.clock.step(0.01)
    rig.close()
    files = recordings(d)
    assert len(files) >= 3
    assert all(r.size < 4096 + 3 * 1024 for r in files)
    total = sum(len(_messages(r.path)) for r in files)
    assert total == 300
    assert rig.health.counters["rotations.size"] == len(files) - 1


def test_rotation_by_duration_uses_the_injected_clock(make_rig, tmp_path):
    d = tmp_path / "rec"
    rig = make_rig(directory=str(d), rotate_seconds=60)
    rig.open()
    for minute in range(3):
        rig.rec.write([_raw(minute)])
        rig.clock.step(59.0)
        rig.rec.flush()  # 59 s: no rotation yet
        assert len(recordings(d)) == minute + 1
        rig.clock.step(1.0)
        rig.rec.flush()  # 60 s: a new file
    rig.close()
    assert _names(d) == [
        "edged-20241123T082000Z.mcap",
        "edged-20241123T082100Z.mcap",
        "edged-20241123T082200Z.mcap",
        "edged-20241123T082300Z.mcap",
    ]
    assert [len(_messages(r.path)) for r in recordings(d)] == [1, 1, 1, 0]


def test_rotate_signal_starts_a_new_file_even_within_the_same_second(make_rig, tmp_path):
    d = tmp_path / "rec"
    rig = make_rig(directory=str(d))
    rig.open()
    rig.rec.write([_raw(0)])
    rig.rec.rotate()
    rig.rec.write([_raw(1)])
    rig.close()
    assert _names(d) == ["edged-20241123T082000Z.mcap", "edged-20241123T082000Z-1.mcap"]
    assert [len(_messages(r.path)) for r in recordings(d)] == [1, 1]


def test_exact_path_is_never_rotated(make_rig, tmp_path):
    rig = make_rig(path=str(tmp_path / "one.mcap"), rotate_bytes=100)
    rig.open()
    for i in range(50):
        rig.rec.write([_raw(i)])
    rig.rec.rotate()
    rig.close()
    assert [p.name for p in tmp_path.iterdir()] == ["one.mcap"]
    assert len(_messages(tmp_path / "one.mcap")) == 50


def test_retention_keeps_the_newest_files(make_rig, tmp_path):
    d = tmp_path / "rec"
    d.mkdir()
    (d / "notes.txt").write_text("mine")
    (d / "edged-20200101T000000Z.recovered.mcap").write_bytes(b"x")
    rig = make_rig(directory=str(d), keep_files=2)
    rig.open()
    for i in range(4):
        rig.rec.write([_raw(i)])
        rig.clock.step(1.0)
        rig.rec.rotate()
    rig.close()
    assert _names(d) == ["edged-20241123T082003Z.mcap", "edged-20241123T082004Z.mcap"]
    assert (d / "notes.txt").exists() and (d / "edged-20200101T000000Z.recovered.mcap").exists()
    assert rig.health.counters["files_deleted"] == 3


def test_retention_by_size_deletes_oldest_beyond_the_budget(tmp_path):
    sizes = {"edged-20241123T080000Z.mcap": 400, "edged-20241123T080000Z-1.mcap": 300, "edged-20241123T090000Z.mcap": 500}
    for name, size in sizes.items():
        (tmp_path / name).write_bytes(b"x" * size)
    current = tmp_path / "edged-20241123T090000Z.mcap"
    deleted = prune(tmp_path, None, 850, current)
    assert [p.name for p in deleted] == ["edged-20241123T080000Z.mcap"]  # -1 is newer than the plain name
    # The current file stays even when it alone is over the budget.
    assert prune(tmp_path, None, 100, current) == [tmp_path / "edged-20241123T080000Z-1.mcap"]
    assert _names(tmp_path) == ["edged-20241123T090000Z.mcap"]


def test_keep_gib_is_applied_on_rotation(make_rig, tmp_path):
    d = tmp_path / "rec"
    d.mkdir()
    for h in range(3):
        (d / f"edged-20241122T0{h}0000Z.mcap").write_bytes(b"x" * 1000)
    rig = make_rig(directory=str(d), keep_gib=1500 / GIB)
    rig.open()
    rig.close()
    # The new file starts (nearly) empty: it and the newest old file fit 1500 bytes.
    assert _names(d) == ["edged-20241122T020000Z.mcap", "edged-20241123T082000Z.mcap"]


class FreeSpace:
    def __init__(self, free: int) -> None:
        self.free = free
        self.asked: list[Path] = []

    def __call__(self, path: Path) -> int:
        self.asked.append(path)
        return self.free


def test_disk_floor_stops_recording_then_resumes(make_rig, tmp_path):
    d = tmp_path / "rec"
    free = FreeSpace(10 * GIB)
    rig = make_rig(directory=str(d), min_free_gib=1.0, retry_seconds=10, free_bytes=free)
    rig.open()
    rig.rec.write([_raw(0)])
    assert rig.health.state == "recording"
    free.free = GIB // 2
    rig.clock.step(10)
    rig.rec.flush()  # the periodic check sees the floor
    assert rig.health.state == "disk_low"
    assert "below the floor" in rig.health.last_error
    rig.rec.write([_raw(1), _raw(2)])  # dropped, counted, nothing raised
    assert rig.health.counters["dropped.disk_low"] == 2
    rig.clock.step(10)
    rig.rec.flush()  # still low: still stopped
    assert rig.health.state == "disk_low"
    free.free = 5 * GIB
    rig.clock.step(10)
    rig.rec.flush()  # retried: recording again, in a new file
    assert rig.health.state == "recording"
    rig.rec.write([_raw(3)])
    rig.close()
    files = recordings(d)
    assert [len(_messages(r.path)) for r in files] == [1, 1]  # the stopped file was finished cleanly
    assert free.asked and all(p == d for p in free.asked)


def test_disk_low_at_start_does_not_raise_and_retries(make_rig, tmp_path):
    free = FreeSpace(0)
    rig = make_rig(directory=str(tmp_path / "rec"), free_bytes=free, retry_seconds=5)
    rig.open()
    assert rig.health.state == "disk_low"
    rig.rec.write([_raw(0)])
    free.free = 100 * GIB
    rig.clock.step(5)
    rig.rec.flush()
    assert rig.health.state == "recording"


class FailingFile(io.BytesIO):
    """A file that accepts `budget` bytes, then fails like a full disk (or `err`)."""

    def __init__(self, budget: int, err: int = errno.ENOSPC) -> None:
        super().__init__()
        self.budget = budget
        self.err = err

    def write(self, b) -> int:  # type: ignore[override]
        if self.tell() + len(b) > self.budget:
            raise OSError(self.err, "simulated")
        return super().write(b)


@pytest.mark.parametrize(("err", "state"), [(errno.ENOSPC, "disk_full"), (errno.EIO, "failed")])
def test_write_error_stops_recording_with_a_clear_state(make_rig, tmp_path, err, state):
    opened: list[FailingFile] = []

    def opener(path: Path, mode: str) -> FailingFile:
        opened.append(FailingFile(3000, err))
        return opened[-1]

    rig = make_rig(directory=str(tmp_path / "rec"), chunk_kib=1, compression="none", opener=opener, retry_seconds=30)
    rig.open()
    for i in range(100):
        rig.rec.write([_raw(i)])  # never raises
    assert rig.health.state == state
    assert "write failed" in rig.health.last_error
    assert rig.health.counters[f"stops.{state}"] == 1
    assert rig.health.counters[f"dropped.{state}"] > 0
    assert rig.rec.status()["recording"] is False
    rig.rec.flush()
    rig.clock.step(30)
    rig.rec.flush()  # retried later in a new file
    assert len(opened) == 2 and rig.health.state == "recording"
    rig.close()


class FullDisk(io.FileIO):
    """A real file whose disk fills up when the test says so."""

    full = False

    def write(self, b) -> int:  # type: ignore[override]
        if FullDisk.full:
            raise OSError(errno.ENOSPC, "No space left on device")
        return super().write(b)


def test_write_error_of_a_real_file_keeps_what_was_written(make_rig, tmp_path, monkeypatch):
    monkeypatch.setattr(FullDisk, "full", False)
    rig = make_rig(path=str(tmp_path / "x.mcap"), chunk_kib=1, opener=FullDisk)
    rig.open()
    for i in range(100):
        rig.rec.write([_raw(i)])
    rig.rec.flush()
    monkeypatch.setattr(FullDisk, "full", True)
    for i in range(100, 200):
        rig.rec.write([_raw(i)])
    rig.rec.flush()
    assert rig.health.state == "disk_full"
    monkeypatch.setattr(FullDisk, "full", False)
    rig.clock.step(3600)
    rig.rec.flush()
    assert rig.health.state == "disk_full"  # an exact file is never reopened (it would be truncated)
    rig.close()
    # What was flushed before the disk filled is all there, readable after recovery.
    from edged_mcap.recovery import recover

    res = recover(tmp_path / "x.mcap")
    assert len(_messages(res.output)) >= 100


def test_unwritable_directory_is_a_failed_state_not_an_exception(make_rig, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    rig = make_rig(directory=str(blocker / "rec"))
    rig.open()
    assert rig.health.state == "failed"
    assert "cannot open a recording" in rig.health.last_error
    rig.rec.write([_raw(0)])
    assert rig.health.counters["dropped.failed"] == 1


def test_config_needs_exactly_one_target(make_rig):
    from pydantic import ValidationError

    from edged_mcap.config import McapConfig

    with pytest.raises(ValidationError, match="exactly one"):
        McapConfig.model_validate({"type": "mcap"})
    with pytest.raises(ValidationError, match="exactly one"):
        McapConfig.model_validate({"type": "mcap", "path": "a.mcap", "directory": "d"})
    with pytest.raises(ValidationError):
        McapConfig.model_validate({"type": "mcap", "path": "a.mcap", "chunk_kib": 4096})
    cfg = McapConfig.model_validate({"type": "mcap", "directory": "rec"}, context={"config_dir": Path("/etc/edged")})
    assert cfg.directory == Path("/etc/edged/rec")
