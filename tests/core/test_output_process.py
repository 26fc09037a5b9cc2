"""An output in a process of its own (`worker = "process"`): the same contract as in the
event loop, its health and log mirrored, a crash of its process counted and survived."""

from __future__ import annotations

import asyncio
import logging
import os
from pathlib import Path

import pytest
from waiting import wait_for

from edged.clock import ManualClock
from edged.config import parse_config
from edged.plugin import OutputPlugin
from edged.records import Measurement
from edged.runtime import Runtime
from edged.supervisor import RestartPolicy

SAFETY = 60.0  # seconds: only a broken output ever waits this long


async def _no_wait(delay: float) -> None:
    await asyncio.sleep(0)


def _runtime(registry, path: Path, **extra) -> tuple[Runtime, ManualClock]:
    out = {"type": "file", "worker": "process", "path": str(path), **extra}
    clock = ManualClock(100.0)
    # (replay: no health timer, whose snapshots a loaded machine's slow start of the
    # process put among the records counted here)
    rt = Runtime(parse_config({"outputs": {"f": out}}, registry), registry, clock, replay=True,
                 restart=RestartPolicy(initial=0.01), sleep=_no_wait)
    return rt, clock


def _m(t: float) -> Measurement:
    return Measurement("heading", "gyro", t, {"heading": 1.0})


def _lines(path: Path) -> list[tuple[int, list[str]]]:
    out = []
    for line in path.read_text().splitlines():
        pid, *rest = line.split()
        out.append((int(pid), rest))
    return out


def test_records_reach_the_process_whole_in_order_with_the_clock_and_its_health_comes_back(
    registry, tmp_path, caplog
):
    path = tmp_path / "out.txt"
    times = [100.0 + 0.01 * i for i in range(3000)]

    async def main():
        rt, clock = _runtime(registry, path)
        await rt.start()
        host = rt.outputs[0]
        await wait_for(lambda: host.up)
        for k in range(0, len(times), 100):
            for t in times[k : k + 100]:
                clock.set(t)
                rt.router.publish(_m(t))
            await asyncio.sleep(0)  # (the host takes what is queued: one batch per stretch)
        await wait_for(lambda: host.health.counters.get("seen", 0) == len(times))
        rt.tick()  # a flush
        rt.rotate()
        await wait_for(lambda: host.plugin.status() is not None and host.health.info.get("pid") is not None)
        snap = rt.health_snapshot()["outputs"]["f"]
        await rt.stop()
        return snap

    with caplog.at_level(logging.INFO):
        snap = asyncio.run(main())
    lines = _lines(path)
    pids = {pid for pid, _ in lines}
    assert len(pids) == 1 and os.getpid() not in pids
    (child,) = pids
    events = [rest[0] for _, rest in lines]
    assert events[0] == "open" and events[-1] == "close"
    assert "flush" in events and "rotate" in events
    writes = [rest for _, rest in lines if rest[:2] == ["write", "Measurement"]]
    assert [float(t) for _, _, t, _ in writes] == times
    # each record was handed over at a moment of the parent's clock at or after its own time
    published = set(times)
    assert all(float(now) >= float(t) and float(now) in published for _, _, t, now in writes)
    # the child's health, mirrored: its counter, its state, its info and its status
    assert snap["counters"]["seen"] == len(times) and snap["counters"]["written"] == len(times)
    assert snap["state"] == "writing"
    assert snap["info"]["pid"] == child and snap["info"]["lines_pid"] == child
    # and its log, re-emitted in the parent under the plugin's logger
    assert any(r.name == "edged.f" and f"pid={child}" in r.getMessage() for r in caplog.records)


def test_a_crashed_process_is_counted_restarted_and_takes_the_records_after(registry, tmp_path):
    path = tmp_path / "out.txt"

    async def main():
        rt, clock = _runtime(registry, path, crash_at=100.5)
        await rt.start()
        host = rt.outputs[0]
        await wait_for(lambda: host.up)
        first = host.plugin.pid
        for t in (100.0, 100.1, 100.2):
            rt.router.publish(_m(t))
        await wait_for(lambda: host.health.counters.get("seen", 0) == 3)
        rt.router.publish(_m(100.5))  # the process exits at once (code 3)
        await wait_for(lambda: host.health.restarts >= 1 and host.up and host.plugin.pid not in (None, first))
        for t in (100.6, 100.7):
            rt.router.publish(_m(t))
        await wait_for(lambda: host.health.counters.get("seen", 0) == 5)
        h = host.health
        counters, restarts, error = dict(h.counters), h.restarts, h.last_error
        await rt.stop()
        return counters, restarts, error

    counters, restarts, error = asyncio.run(main())
    assert counters["dropped.process_died"] == 1
    assert restarts == 1
    assert "exit code 3" in error
    lines = _lines(path)
    assert len({pid for pid, rest in lines if rest == ["open"]}) == 2  # a second process
    assert [float(rest[2]) for _, rest in lines if rest[:2] == ["write", "Measurement"]] == [
        100.0, 100.1, 100.2, 100.6, 100.7
    ]


def test_a_plugin_raising_in_its_process_is_reported_with_its_message(registry, tmp_path):
    path = tmp_path / "out.txt"

    async def main():
        rt, _ = _runtime(registry, path, raise_at=100.2)
        await rt.start()
        host = rt.outputs[0]
        await wait_for(lambda: host.up)
        rt.router.publish(_m(100.2))
        await wait_for(lambda: host.health.restarts >= 1)
        error = host.health.last_error
        await rt.stop()
        return error

    assert "record at t=100.2 refused" in asyncio.run(main())


@pytest.mark.parametrize("where", ["loop", "process"])
def test_a_batch_the_plugin_raised_on_is_counted_lost(registry, tmp_path, where):
    """Every record is written or counted lost: the batch a plugin's `write` raised on
    (in either placement) is `dropped.write_failed`, beside the restart."""
    path = tmp_path / "out.txt"

    async def main():
        rt, _ = _runtime(registry, path, raise_at=100.2, worker=where)
        await rt.start()
        host = rt.outputs[0]
        await wait_for(lambda: host.up)
        for i in range(5):
            rt.router.publish(_m(100.0 + 0.1 * i))
        await wait_for(lambda: host.health.restarts >= 1)
        await rt.stop()
        return host.health.counters

    c = asyncio.run(main())
    written = [rest for _, rest in _lines(path) if rest[:2] == ["write", "Measurement"]]
    assert c["dropped.write_failed"] >= 1, c
    assert len(written) + c["dropped.write_failed"] >= 5, (written, c)


def test_an_open_that_fails_in_its_process_fails_the_writes_sent_behind_it_and_says_why(registry, tmp_path):
    """The host sends its batches behind the process's start and open without waiting
    for them (issue 34): an open that failed there refuses what follows, with the
    open's reason, and every record is counted lost, none written."""
    path = tmp_path / "out.txt"

    async def main():
        rt, _ = _runtime(registry, path, fail_open=True)
        await rt.start()
        host = rt.outputs[0]
        for i in range(5):
            rt.router.publish(_m(100.0 + i))
        await wait_for(lambda: host.health.restarts >= 1)
        error = host.health.last_error
        await rt.stop()
        return host, error

    host, error = asyncio.run(main())
    assert "not open (open: OSError: the disk said no)" in error
    assert not host.up
    c = host.health.counters
    lost = sum(v for k, v in c.items() if k.startswith("dropped.")) + c.get("overflow", 0)
    assert [rest for _, rest in _lines(path) if rest[0] == "write"] == []
    assert lost == 5, c


def test_stopped_while_its_process_starts_it_still_writes_what_was_queued(registry, tmp_path):
    path = tmp_path / "out.txt"

    async def main():
        rt, _ = _runtime(registry, path)
        await rt.start()
        for i in range(10):
            rt.router.publish(_m(100.0 + i))
        await rt.stop()  # (the child is most likely still importing)

    asyncio.run(main())
    writes = [float(rest[2]) for _, rest in _lines(path) if rest[:2] == ["write", "Measurement"]]
    assert writes == [100.0 + i for i in range(10)]


def test_an_output_that_cannot_be_pickled_runs_in_the_loop_and_says_so(registry, tmp_path, caplog):
    class LocalOutput(OutputPlugin):  # made inside a function: no process can import it
        def write(self, batch):
            self.got = getattr(self, "got", []) + batch

    registry.register("outputs", "local", LocalOutput)
    cfg = parse_config({"outputs": {"l": {"type": "local", "worker": "process"}}}, registry)
    with caplog.at_level(logging.WARNING):
        rt = Runtime(cfg, registry, ManualClock(100.0))
    assert rt.outputs[0].plugin.plugin.__class__ is LocalOutput  # (in its loop placement)
    assert any("event=output-in-loop output=l" in r.getMessage() for r in caplog.records)

    async def main():
        await rt.start()
        rt.router.publish(_m(100.0))
        await rt.stop()

    asyncio.run(main())
    assert [r.t for r in rt.outputs[0].plugin.plugin.got] == [100.0]


@pytest.mark.parametrize("bad", ["thread", 3])
def test_worker_takes_only_loop_or_process(registry, tmp_path, bad):
    from edged.config import ConfigError

    with pytest.raises(ConfigError, match="outputs.f"):
        parse_config({"outputs": {"f": {"type": "file", "path": str(tmp_path / "x"), "worker": bad}}}, registry)
