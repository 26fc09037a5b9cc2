"""Thousands of files on one replay's command line cost what the overlapping ones cost.

All files were open at once (one descriptor and reader each), every file's input was
in each health snapshot, and the estimator workers queued those snapshots whole:
250 files took 224 MB, 1,000 files 1.7 GB and 1,010 descriptors, and 10,000 ignored
SIGTERM for over 30 s while their first records were read (issue 32). Now a file is
opened when the replay reaches its first record and closed at its end, leaves the
health snapshot then (its counters stay for the summary), and a worker takes a health
record as a time beacon.
"""

from __future__ import annotations

import asyncio
import heapq
import random
from pathlib import Path
from typing import Any, BinaryIO, Iterator

import pytest
from core_dummies import DummyInput, ListOutput

from edged.clock import ReplayClock
from edged.config import parse_config
from edged.health import ComponentHealth
from edged.plugin import ReplayOptions
from edged.records import HealthRecord, RawRecord
from edged.registry import Registry
from edged.replay import Replayer
from edged.router import Router
from edged.runtime import Runtime


class CountedLog:
    """`#n` files of `<t>` lines; counts the readers open at once and every open."""

    name = "counted"
    protocol = "dummy"
    input = "dummy"
    priority = 50

    def __init__(self) -> None:
        self.open_now = 0
        self.most_open = 0
        self.opens = 0
        self.on_open: Any = None

    def sniff(self, head: bytes) -> bool:
        return head.startswith(b"#n\n")

    def open(self, stream: BinaryIO, source: str, health: ComponentHealth,
             options: ReplayOptions) -> Iterator[RawRecord]:
        self.opens += 1
        if self.on_open is not None:
            self.on_open(self.opens)
        self.open_now += 1
        self.most_open = max(self.most_open, self.open_now)
        try:
            for line in stream:
                if line.startswith(b"#"):
                    continue
                health.count("lines")
                yield RawRecord("dummy", source, float(line), line.strip())
        finally:
            self.open_now -= 1


def _registry(log: CountedLog) -> Registry:
    r = Registry(use_entry_points=False)
    r.register("inputs", "dummy", DummyInput)
    r.register("outputs", "list", ListOutput)
    r.register("logs", "counted", log)
    return r


def _write(folder: Path, times: list[list[float]]) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for j, ts in enumerate(times):
        p = folder / f"f{j:05d}.n"
        p.write_text("#n\n" + "".join(f"{t!r}\n" for t in ts))
        paths.append(p)
    return paths


def _replayer(log: CountedLog, paths: list[Path]) -> tuple[Runtime, Replayer]:
    ListOutput.instances.clear()
    reg = _registry(log)
    rt = Runtime(parse_config({"outputs": {"rec": {"type": "list"}}}, reg), reg, ReplayClock(), replay=True)
    return rt, Replayer(rt, paths)


async def _replay(log: CountedLog, paths: list[Path]) -> tuple[Runtime, list[Any], Replayer]:
    rt, rep = _replayer(log, paths)
    await rt.start()
    try:
        await rep.run()
    finally:
        await rt.stop()
    return rt, ListOutput.instances[0].records, rep


@pytest.mark.parametrize("n", [3, 40, 400])
async def test_files_one_after_another_are_open_one_at_a_time(tmp_path, n):
    t0 = 1_700_000_000.0
    paths = _write(tmp_path, [[t0 + 60 * j + 10 * k for k in range(3)] for j in range(n)])
    log = CountedLog()
    rt, recs, rep = await _replay(log, paths)
    raws = [r for r in recs if isinstance(r, RawRecord)]
    assert [r.t for r in raws] == [t0 + 60 * j + 10 * k for j in range(n) for k in range(3)]
    assert log.most_open == 1  # each file's first time is read by a reader closed at once
    assert log.opens == 2 * n and log.open_now == 0
    assert not rep._streams  # every file closed at its end
    # Every file's counters stay for the summary; the last snapshot holds only what runs.
    inputs = [h for h in rt.health.components.values() if h.role == "input"]
    assert len(inputs) == n and all(h.counters["lines"] == 3 for h in inputs)
    last = [r for r in recs if isinstance(r, HealthRecord)][-1].values
    assert set(last.get("inputs", {})) <= {paths[-1].stem}


@pytest.mark.parametrize("seed", range(12))
async def test_overlapping_files_come_out_as_heapq_merges_them(tmp_path, seed):
    rng = random.Random(seed)
    n = rng.randint(3, 12)
    # whole seconds make ties between files; some files empty, some far apart
    times = [sorted(float(rng.randint(0, 30) + 100 * rng.randint(0, 2)) for _ in range(rng.randint(0, 8)))
             for _ in range(n)]
    paths = _write(tmp_path, times)
    _rt, recs, _ = await _replay(CountedLog(), paths)
    got = [(r.source, r.t) for r in recs if isinstance(r, RawRecord)]
    each = [[(p.stem, t) for t in ts] for p, ts in zip(paths, times)]
    assert got == list(heapq.merge(*each, key=lambda st: st[1]))


async def test_a_stop_while_thousands_of_first_times_are_read_is_heard_within_a_few_files(tmp_path):
    paths = _write(tmp_path, [[1_700_000_000.0 + j] for j in range(400)])
    log = CountedLog()
    rt, rep = _replayer(log, paths)
    await rt.start()
    try:
        task = asyncio.get_running_loop().create_task(rep.run())
        log.on_open = lambda k: task.cancel() if k == 5 else None  # SIGTERM's handler cancels it
        with pytest.raises(asyncio.CancelledError):
            await task
    finally:
        await rt.stop()
    assert log.opens <= 16  # the loop was looked at within 16 files, not after 400
    assert log.open_now == 0


def test_an_estimator_worker_takes_a_health_record_as_a_time_beacon():
    router = Router()
    worker = router.subscribe("estimator:w", {"health"}, sequenced=True)
    output = router.subscribe("output:o", None)
    snap = {"t": 5.0, "inputs": {f"s{i}": {"counters": {"lines": i}} for i in range(1000)}}
    router.publish(HealthRecord(5.0, snap))
    (seq, beacon), = worker.queue.drain_nowait()
    assert isinstance(beacon, HealthRecord) and beacon.t == 5.0 and beacon.values == {}
    (whole,) = output.queue.drain_nowait()
    assert whole.values is snap  # the outputs publish and record it whole
